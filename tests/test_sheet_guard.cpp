// The tunnelling guard's geometry (P8 stage 5, SheetGuard_K.hpp). The segment-triangle test against
// an independent one: the signs of the segment's ends against the plane and of the three signed
// volumes the segment makes with the triangle's edges (no division), on random triangles and
// segments, in double and float; the crossing point against the plane's.
#include "kernels/coupling/SheetGuard_K.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>

using namespace kf;

namespace {

double orient(const Vec3d& a, const Vec3d& b, const Vec3d& c, const Vec3d& d) {
  return dot(cross(b - a, c - a), d - a);
}

/// Crossing by signs: the ends on opposite sides of the plane (or one on it) and the segment's
/// line passing inside the triangle (the three volumes of one sign).
bool crosses_by_signs(const Vec3d& p, const Vec3d& q, const Vec3d& a, const Vec3d& b,
                      const Vec3d& c) {
  const double sp = orient(a, b, c, p), sq = orient(a, b, c, q);
  if ((sp > 0 && sq > 0) || (sp < 0 && sq < 0))
    return false;
  const double v1 = orient(p, q, a, b), v2 = orient(p, q, b, c), v3 = orient(p, q, c, a);
  return (v1 >= 0 && v2 >= 0 && v3 >= 0) || (v1 <= 0 && v2 <= 0 && v3 <= 0);
}

} // namespace

TEST(SheetGuard, SegmentTriangleAgreesWithTheSignsTest) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  auto point = [&] { return Vec3d{u(rng), u(rng), u(rng)}; };
  int crossings = 0, checked = 0;
  for (int k = 0; k < 200000; ++k) {
    const Vec3d a = point(), b = point(), c = point(), p = point(), q = point();
    // Cases within rounding of an edge or the plane may go either way: skip them.
    const double sp = orient(a, b, c, p), sq = orient(a, b, c, q);
    const double v1 = orient(p, q, a, b), v2 = orient(p, q, b, c), v3 = orient(p, q, c, a);
    const double eps = 1e-9;
    if (std::abs(sp) < eps || std::abs(sq) < eps || std::abs(v1) < eps || std::abs(v2) < eps ||
        std::abs(v3) < eps)
      continue;
    ++checked;
    const bool expect = crosses_by_signs(p, q, a, b, c);
    const auto got = segment_crosses_triangle(p, q, a, b, c);
    ASSERT_EQ(got.crosses, expect) << "case " << k;
    if (!expect)
      continue;
    ++crossings;
    // The crossing point lies in the plane; the normal is unit and faces p.
    const Vec3d x = p + (q - p) * got.s;
    EXPECT_NEAR(dot(got.n, x - a), 0.0, 1e-9);
    EXPECT_NEAR(norm(got.n), 1.0, 1e-12);
    EXPECT_GT(dot(got.n, p - a), 0.0);
  }
  EXPECT_GT(checked, 190000);
  EXPECT_GT(crossings, 1000) << "too few crossings to test the crossing point";
}

// A fluid particle stepping through the middle of a face crosses it in float too, and a step
// that stops short, one beside the face and one in its plane do not.
TEST(SheetGuard, FloatCasesOnAKnitFace) {
  const Vec3<float> a{0, 0, 0}, b{0.004f, 0, 0}, c{0, 0.004f, 0};
  const Vec3<float> above{0.001f, 0.001f, 0.001f};
  EXPECT_TRUE(
      segment_crosses_triangle(above, Vec3<float>{0.001f, 0.001f, -0.0005f}, a, b, c).crosses);
  EXPECT_FALSE(
      segment_crosses_triangle(above, Vec3<float>{0.001f, 0.001f, 0.0002f}, a, b, c).crosses);
  EXPECT_FALSE(segment_crosses_triangle(Vec3<float>{0.005f, 0.005f, 0.001f},
                                        Vec3<float>{0.005f, 0.005f, -0.001f}, a, b, c)
                   .crosses);
  EXPECT_FALSE(segment_crosses_triangle(Vec3<float>{-0.001f, 0.001f, 0},
                                        Vec3<float>{0.003f, 0.001f, 0}, a, b, c)
                   .crosses);
}

namespace {

/// A point and a triangle's corners, each moving linearly over t in [0, 1].
struct Motion {
  Vec3d p0, p1, a0, a1, b0, b1, c0, c1;
  static Vec3d at(const Vec3d& x0, const Vec3d& x1, double t) { return x0 + (x1 - x0) * t; }
  double volume(double t) const {
    return orient(at(a0, a1, t), at(b0, b1, t), at(c0, c1, t), at(p0, p1, t));
  }
  /// The point's barycentric weights of b and c at t, from the plane's projection.
  std::pair<double, double> weights(double t) const {
    const Vec3d a = at(a0, a1, t), e1 = at(b0, b1, t) - a, e2 = at(c0, c1, t) - a,
                q = at(p0, p1, t) - a;
    const double d00 = dot(e1, e1), d01 = dot(e1, e2), d11 = dot(e2, e2), d20 = dot(q, e1),
                 d21 = dot(q, e2), den = d00 * d11 - d01 * d01;
    return {(d11 * d20 - d01 * d21) / den, (d00 * d21 - d01 * d20) / den};
  }
};

/// The reference: the signed volume sampled at n + 1 times; the first sign change whose root
/// (linear within the sample) lies inside the triangle. `clear` is false where the case is too
/// close to call at this sampling: two sign changes within a few samples, or a root within 1e-3
/// of an edge in barycentric terms.
struct Sampled {
  bool meets = false, clear = true;
  double t = 0;
};
Sampled sample_meeting(const Motion& m, int n) {
  Sampled out;
  double prev = m.volume(0.0);
  int last_change = -100;
  for (int k = 1; k <= n; ++k) {
    const double t1 = double(k) / n, f1 = m.volume(t1);
    if ((prev > 0) != (f1 > 0)) {
      if (k - last_change < 4)
        out.clear = false;
      last_change = k;
      const double t0 = double(k - 1) / n, t = t0 + (t1 - t0) * prev / (prev - f1);
      const auto [wb, wc] = m.weights(t);
      const double clearance = std::min({wb, wc, 1 - wb - wc});
      if (std::abs(clearance) < 1e-3)
        out.clear = false;
      if (!out.meets && clearance > 0) {
        out.meets = true;
        out.t = t;
      }
    }
    prev = f1;
  }
  return out;
}

} // namespace

// Continuous collision of a point with a moving triangle (point_meets_moving_triangle) against
// the signed volume sampled at 4096 times on random motions (corners and point each moving up
// to the triangle's size), in double: whether they meet, when (within two samples), and the
// side the point came from. Among the meetings, those a test against the triangle where it ends
// (the step's segment against the face at the step's end) gets wrong show that the motion
// matters.
TEST(SheetGuard, MovingTriangleAgreesWithSampledMotion) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  auto point = [&] { return Vec3d{u(rng), u(rng), u(rng)}; };
  const int n = 4096;
  int checked = 0, meetings = 0, end_frame_wrong = 0;
  for (int k = 0; k < 60000; ++k) {
    Motion m;
    m.a0 = point();
    m.b0 = point();
    m.c0 = point();
    m.p0 = point();
    m.a1 = m.a0 + point() * 0.5;
    m.b1 = m.b0 + point() * 0.5;
    m.c1 = m.c0 + point() * 0.5;
    m.p1 = m.p0 + point();
    const Sampled ref = sample_meeting(m, n);
    if (!ref.clear || std::abs(m.volume(0.0)) < 1e-6)
      continue;
    ++checked;
    const auto got = point_meets_moving_triangle(m.p0, m.p1, m.a0, m.a1, m.b0, m.b1, m.c0, m.c1);
    ASSERT_EQ(got.meets, ref.meets) << "case " << k << ", reference t " << ref.t;
    if (!ref.meets)
      continue;
    ++meetings;
    EXPECT_NEAR(got.t, ref.t, 2.0 / n) << "case " << k;
    EXPECT_EQ(got.side, m.volume(0.0) > 0 ? 1.0 : -1.0) << "case " << k;
    const auto [wb, wc] = m.weights(got.t);
    EXPECT_NEAR(got.wb, wb, 1e-6);
    EXPECT_NEAR(got.wc, wc, 1e-6);
    end_frame_wrong += !segment_crosses_triangle(m.p0, m.p1, m.a1, m.b1, m.c1).crosses;
  }
  EXPECT_GT(checked, 59000);
  EXPECT_GT(meetings, 1500); // ~3% of random motions meet (seed 11: 1,950)
  EXPECT_GT(end_frame_wrong, meetings / 10) << "the motions hardly test the faces' motion";
  std::printf("%d cases, %d meetings, %d of them missed by the end-frame segment test\n", checked,
              meetings, end_frame_wrong);
}

// At rest the continuous test is the segment test: the same answer, the meeting at the same
// place along the step.
TEST(SheetGuard, ATriangleAtRestMeetsWhereTheSegmentCrosses) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  auto point = [&] { return Vec3d{u(rng), u(rng), u(rng)}; };
  int crossings = 0, checked = 0;
  for (int k = 0; k < 100000; ++k) {
    const Vec3d a = point(), b = point(), c = point(), p = point(), q = point();
    const double sp = orient(a, b, c, p), sq = orient(a, b, c, q);
    const double v1 = orient(p, q, a, b), v2 = orient(p, q, b, c), v3 = orient(p, q, c, a);
    const double eps = 1e-6; // the meeting's barycentric bounds are widened by 1e-5
    if (std::abs(sp) < eps || std::abs(sq) < eps || std::abs(v1) < eps || std::abs(v2) < eps ||
        std::abs(v3) < eps)
      continue;
    ++checked;
    const auto seg = segment_crosses_triangle(p, q, a, b, c);
    const auto got = point_meets_moving_triangle(p, q, a, a, b, b, c, c);
    if (got.meets != seg.crosses) { // only within the widened bounds' reach of an edge
      const double area = norm(cross(b - a, c - a));
      EXPECT_LT(std::min({std::abs(v1), std::abs(v2), std::abs(v3)}) / area, 1e-4) << k;
      continue;
    }
    if (!seg.crosses)
      continue;
    ++crossings;
    EXPECT_NEAR(got.t, seg.s, 1e-9) << "case " << k;
    EXPECT_EQ(got.side, sp > 0 ? 1.0 : -1.0);
  }
  EXPECT_GT(checked, 95000);
  EXPECT_GT(crossings, 1000);
}

// A particle put back keeps or loses speed along the face's normal, never gains it: the value
// between its own and the face's nearest zero.
TEST(SheetGuard, PutBackNeverSpeedsAParticleUp) {
  EXPECT_EQ(guarded_normal_speed(-3.0, 2.0), 0.0);   // into a face coming at it: stopped
  EXPECT_EQ(guarded_normal_speed(-3.0, -1.0), -1.0); // a face moving away slower: its speed
  EXPECT_EQ(guarded_normal_speed(-1.0, -3.0), -1.0); // faster: its own
  EXPECT_EQ(guarded_normal_speed(2.0, 5.0), 2.0);    // a face sweeping into it: no more than it had
  EXPECT_EQ(guarded_normal_speed(0.0, 5.0), 0.0);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-10.0, 10.0);
  for (int k = 0; k < 10000; ++k) {
    const double un = u(rng), fn = u(rng), g = guarded_normal_speed(un, fn);
    EXPECT_LE(std::abs(g), std::abs(un));
    EXPECT_LE(std::min(un, fn), g);
    EXPECT_LE(g, std::max(un, fn));
  }
}
