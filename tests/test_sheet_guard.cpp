// The tunnelling guard's segment-triangle test (P8 stage 5, SheetGuard_K.hpp) against an
// independent one: the signs of the segment's ends against the plane and of the three signed
// volumes the segment makes with the triangle's edges (no division), on random triangles and
// segments, in double and float; the crossing point against the plane's.
#include "kernels/coupling/SheetGuard_K.hpp"

#include <gtest/gtest.h>

#include <cmath>
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
