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

namespace {

/// A small reaction problem: knit points, faces over them (one normal each), particles that met
/// a face at given weights. Runs the reaction's two evaluators as the guard does (counts, then
/// each particle, then each point) on the host.
struct Reaction {
  std::vector<Vec3d> kv, v;
  std::vector<double> km, m;
  std::vector<std::uint32_t> handle, vertex, face;
  std::vector<Vec3d> w, n;
  std::vector<std::uint64_t> sums;
  double quantum = std::ldexp(20.0, -40); // a speed of sound of 20 m/s, as the guard takes it

  void run() {
    sums.assign(kSheetSumWidth * kv.size(), 0);
    for (std::uint32_t f : face)
      for (int e = 0; e < 3; ++e)
        sums[kSheetSumWidth * vertex[3 * f + e]] += 1;
    const SheetFacesView sheet{vertex.data(), nullptr, nullptr, nullptr};
    const SheetHits<double> hits{face.data(), w.data(), n.data()};
    const SheetReactionEvaluator<double> react{v.data(),    m.data(),     nullptr,       hits,
                                               kv.data(),   km.data(),    handle.data(), sheet,
                                               sums.data(), 1.0 / quantum};
    for (std::size_t j = 0; j < v.size(); ++j)
      react(j);
    const SheetKickEvaluator<double> kick{kv.data(), handle.data(), sums.data(), quantum};
    for (std::size_t i = 0; i < kv.size(); ++i)
      kick(i);
  }
  Vec3d momentum() const {
    Vec3d p{0, 0, 0};
    for (std::size_t i = 0; i < kv.size(); ++i)
      p = p + kv[i] * km[i];
    for (std::size_t j = 0; j < v.size(); ++j)
      p = p + v[j] * m[j];
    return p;
  }
  double energy() const {
    double e = 0;
    for (std::size_t i = 0; i < kv.size(); ++i)
      e += 0.5 * km[i] * norm2(kv[i]);
    for (std::size_t j = 0; j < v.size(); ++j)
      e += 0.5 * m[j] * norm2(v[j]);
    return e;
  }
};

} // namespace

// k equal particles meeting a free face at its centre, the face at rest: the mass splitting
// makes the reaction one perfectly inelastic collision of them all with the three corners, so
// every particle and every corner ends at k m u / (k m + 3 M) along the normal (momentum
// balance), and nothing moves across it.
TEST(SheetGuard, ReactionOfManyParticlesOnOneFaceIsOneInelasticCollision) {
  for (int k : {1, 2, 5, 40}) {
    Reaction r;
    r.kv.assign(3, Vec3d{0, 0, 0});
    r.km.assign(3, 2e-4); // kg, a knit point
    r.handle.assign(3, kNoHandle);
    r.vertex = {0, 1, 2};
    const double mf = 1e-6, u = -10.0; // a fluid particle (1 mm water) at 10 m/s into the face
    for (int j = 0; j < k; ++j) {
      r.v.push_back(Vec3d{0.3, -0.2, u});
      r.m.push_back(mf);
      r.face.push_back(0);
      r.w.push_back(Vec3d{1.0 / 3, 1.0 / 3, 1.0 / 3});
      r.n.push_back(Vec3d{0, 0, 1}); // it came from above
    }
    const Vec3d p0 = r.momentum();
    const double e0 = r.energy();
    r.run();
    const double common = k * mf * u / (k * mf + 3 * 2e-4);
    for (int j = 0; j < k; ++j) {
      EXPECT_NEAR(r.v[j].z, common, 1e-12 * std::abs(u)) << k << " particles";
      EXPECT_EQ(r.v[j].x, 0.3); // along the face: untouched
      EXPECT_EQ(r.v[j].y, -0.2);
    }
    for (int i = 0; i < 3; ++i) {
      // The corners' sums resolve 2^-40 of 20 m/s (1.8e-11 m/s) per particle.
      EXPECT_NEAR(r.kv[i].z, common, 2e-11 * k) << k << " particles, corner " << i;
      EXPECT_EQ(r.kv[i].x, 0.0);
    }
    const Vec3d p1 = r.momentum();
    EXPECT_NEAR(p1.z, p0.z, 2e-11 * k * 2e-4 * 3) << k;
    EXPECT_LT(r.energy(), e0);
  }
}

// Random problems (faces sharing corners at random normals, particles at random weights and
// speeds, some moving away from their face, a few corners pinned at rest): the kinetic energy
// never rises, and momentum is kept when no corner is pinned; a particle moving away from its
// face, or any particle on a face of pinned corners at rest, ends with no normal speed toward it.
TEST(SheetGuard, ReactionKeepsMomentumAndNeverAddsEnergy) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1.0, 1.0), pos(0.0, 1.0);
  int approaching = 0, stopped = 0;
  for (int trial = 0; trial < 2000; ++trial) {
    const bool pinned = trial % 2 == 1;
    Reaction r;
    const int points = 6, faces = 4;
    for (int i = 0; i < points; ++i) {
      r.kv.push_back(Vec3d{u(rng), u(rng), u(rng)} * 2.0);
      r.km.push_back(1e-4 * (0.2 + pos(rng)));
      // Pinned: points 0 and 3 (no face wholly pinned), or 0, 2, 4 (faces 0 and 2 wholly).
      const bool pin = trial % 4 == 3 ? i % 2 == 0 : i % 3 == 0;
      r.handle.push_back(pinned && pin ? 0u : kNoHandle);
      if (r.handle.back() != kNoHandle)
        r.kv.back() = Vec3d{0, 0, 0};
    }
    std::vector<Vec3d> normal;
    for (int f = 0; f < faces; ++f) {
      for (int e = 0; e < 3; ++e) // three distinct corners
        r.vertex.push_back(static_cast<std::uint32_t>((f + 2 * e) % points));
      Vec3d nn{u(rng), u(rng), u(rng)};
      normal.push_back(nn * (1.0 / std::sqrt(norm2(nn))));
    }
    const int particles = 1 + int(pos(rng) * 30);
    for (int j = 0; j < particles; ++j) {
      const auto f = static_cast<std::uint32_t>(pos(rng) * faces) % faces;
      double a = pos(rng), b = pos(rng);
      if (a + b > 1) {
        a = 1 - a;
        b = 1 - b;
      }
      r.face.push_back(f);
      r.w.push_back(Vec3d{1 - a - b, a, b});
      r.n.push_back(normal[f]);
      r.v.push_back(Vec3d{u(rng), u(rng), u(rng)} * 10.0);
      r.m.push_back(1e-6 * (0.5 + pos(rng)));
    }
    const auto before = r.v;
    const Vec3d p0 = r.momentum();
    const double e0 = r.energy();
    r.run();
    // Energy: no rise past the sums' rounding (2^-40 of 20 m/s a particle on a corner).
    EXPECT_LE(r.energy(), e0 * (1 + 1e-9)) << "trial " << trial;
    if (!pinned) {
      const Vec3d p1 = r.momentum();
      EXPECT_NEAR(p1.x, p0.x, 1e-13 + 1e-12 * particles) << "trial " << trial;
      EXPECT_NEAR(p1.y, p0.y, 1e-13 + 1e-12 * particles) << "trial " << trial;
      EXPECT_NEAR(p1.z, p0.z, 1e-13 + 1e-12 * particles) << "trial " << trial;
    }
    for (int j = 0; j < particles; ++j) {
      const Vec3d d = r.v[j] - before[j];
      // Only along the face's normal, and only ever away from the face.
      EXPECT_NEAR(norm2(d - r.n[j] * dot(d, r.n[j])), 0.0, 1e-20);
      EXPECT_GE(dot(d, r.n[j]), 0.0);
      const std::uint32_t f = r.face[j];
      bool all_pinned = true;
      double uf = 0;
      for (int e = 0; e < 3; ++e) {
        const std::uint32_t c = r.vertex[3 * f + e];
        all_pinned = all_pinned && r.handle[c] != kNoHandle;
        uf += (&r.w[j].x)[e] * dot(r.kv[c], r.n[j]);
      }
      if (dot(before[j], r.n[j]) < 0)
        ++approaching;
      if (all_pinned && dot(before[j], r.n[j]) < 0) {
        ++stopped;
        EXPECT_NEAR(dot(r.v[j], r.n[j]), 0.0, 1e-12); // stopped by a face at rest
      }
    }
  }
  EXPECT_GT(approaching, 5000); // the random cases do exercise the reaction
  EXPECT_GT(stopped, 500);
}
