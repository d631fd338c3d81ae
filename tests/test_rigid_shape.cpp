// RigidShape::clear_by, the contact test's cheap first check: wherever it says a point is clear
// of a solid by a margin, distance() must agree (else a particle inside the margin would go
// uncorrected), and it must say so for points clearly far away (else it saves nothing): for
// every shape kind but meshes, at least whenever the distance is sqrt(3) margins (a box's
// corner region, where the bound is the largest axis excess).
#include "kernels/boundary/RigidShape.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>
#include <vector>

using namespace kf;

namespace {

template <typename T>
std::vector<RigidShape<T>> shapes() {
  std::vector<RigidShape<T>> s;
  RigidShape<T> plane;
  plane.kind = ShapeKind::Plane;
  plane.a = {T(0.1), T(0.2), T(0.3)};
  const T r = T(1) / std::sqrt(T(14));
  plane.b = {r, T(2) * r, T(-3) * r};
  s.push_back(plane);
  RigidShape<T> sphere;
  sphere.kind = ShapeKind::Sphere;
  sphere.a = {T(0.2), T(-0.1), T(0.05)};
  sphere.radius = T(0.3);
  s.push_back(sphere);
  RigidShape<T> box;
  box.kind = ShapeKind::Box;
  box.a = {T(-0.2), T(-0.4), T(0.1)};
  box.b = {T(0.3), T(0.1), T(0.25)};
  box.offset = {T(0.05), T(-0.02), T(0.01)}; // a moving box, part way along
  s.push_back(box);
  RigidShape<T> container;
  container.kind = ShapeKind::Container;
  container.a = {T(-0.5), T(-0.5), T(-0.5)};
  container.b = {T(0.5), T(0.4), T(0.6)};
  container.walls = 0x3F & ~(1u << 3); // y+ open
  s.push_back(container);
  return s;
}

template <typename T>
void check() {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-0.8, 0.8);
  const char* names[] = {"plane", "sphere", "box", "container"};
  const auto all = shapes<T>();
  for (std::size_t k = 0; k < all.size(); ++k) {
    const RigidShape<T>& s = all[k];
    for (const double margin : {0.0, 1e-4, 0.01, 0.1, -0.05}) {
      std::size_t clear = 0, far = 0;
      for (int n = 0; n < 20000; ++n) {
        const Vec3<T> x{T(u(rng)), T(u(rng)), T(u(rng))};
        Vec3<T> nrm;
        const double d = double(s.distance(x, nrm));
        const bool c = s.clear_by(x, T(margin));
        ASSERT_TRUE(!c || d >= margin)
            << names[k] << ": clear by " << margin << " but the distance is " << d;
        clear += c;
        if (margin > 0 && d >= std::sqrt(3.0) * margin * (1 + 1e-5) + 1e-6) {
          ++far;
          ASSERT_TRUE(c) << names[k] << ": at distance " << d << " not clear by " << margin;
        }
      }
      if (margin > 0) {
        EXPECT_GT(far, 1000u) << names[k] << ": too few far points to mean anything";
      }
      EXPECT_GT(clear, 1000u) << names[k] << ", margin " << margin;
    }
  }
  // A mesh's sampled distance has no cheap bound: never clear.
  RigidShape<T> mesh;
  mesh.kind = ShapeKind::Mesh;
  EXPECT_FALSE(mesh.clear_by({T(10), T(10), T(10)}, T(0.01)));
}

} // namespace

TEST(RigidShape, ClearByIsAConservativeDistanceBoundFloat) {
  check<float>();
}
TEST(RigidShape, ClearByIsAConservativeDistanceBoundDouble) {
  check<double>();
}
