// Smoothing kernels: normalisation in 3D, antisymmetric gradients, gradient = dW/dr, support.
#include "domain/Samplers.hpp"
#include "kernels/sph/SmoothingKernels.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

using namespace kf;

namespace {

const double kPi = 3.14159265358979323846;

template <typename K>
double radial_integral(const K& k) {
  // Composite Simpson over [0, h] of W(r) 4 pi r^2 (independent of the lattice sum below).
  const int n = 20000;
  const double dr = k.h / n;
  double s = 0;
  for (int i = 0; i <= n; ++i) {
    const double r = i * dr;
    const double w = (i == 0 || i == n) ? 1 : (i % 2 ? 4 : 2);
    s += w * k.W(r) * 4 * kPi * r * r;
  }
  return s * dr / 3;
}

template <typename K>
double lattice_integral(const K& k, int per_h) {
  // Midpoint sum over a 3D Cartesian lattice covering [-h, h]^3.
  const double d = k.h / per_h;
  double s = 0;
  for (int i = -per_h; i < per_h; ++i)
    for (int j = -per_h; j < per_h; ++j)
      for (int l = -per_h; l < per_h; ++l) {
        const double x = (i + 0.5) * d, y = (j + 0.5) * d, z = (l + 0.5) * d;
        s += k.W(std::sqrt(x * x + y * y + z * z));
      }
  return s * d * d * d;
}

class KernelTest : public ::testing::TestWithParam<KernelType> {};

} // namespace

TEST_P(KernelTest, IntegratesToOneIn3D) {
  for (double h : {0.01, 0.37, 2.0}) {
    with_kernel<double>(GetParam(), h, [&](auto k) {
      EXPECT_NEAR(radial_integral(k), 1.0, 1e-8) << "h = " << h;
      EXPECT_NEAR(lattice_integral(k, 60), 1.0, 2e-3) << "h = " << h;
      return 0;
    });
  }
}

TEST_P(KernelTest, SupportRadiusRespected) {
  const double h = 0.05;
  with_kernel<double>(GetParam(), h, [&](auto k) {
    for (double r : {h, h * (1 + 1e-12), 1.5 * h, 10 * h}) {
      EXPECT_EQ(k.W(r), 0.0) << "r = " << r;
      EXPECT_EQ(k.dWdr(r), 0.0);
      const Vec3d g = k.grad(Vec3d{r, 0, 0}, r);
      EXPECT_EQ(norm(g), 0.0);
    }
    // Positive and non-increasing inside the support.
    double prev = k.W(0);
    EXPECT_GT(prev, 0);
    for (int i = 1; i < 1000; ++i) {
      const double w = k.W(h * i / 1000.0);
      EXPECT_GT(w, 0);
      EXPECT_LE(w, prev + 1e-12 * prev);
      prev = w;
    }
    return 0;
  });
}

TEST_P(KernelTest, GradientAntisymmetricAndMatchesFiniteDifferences) {
  const double h = 0.1;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-h, h);
  with_kernel<double>(GetParam(), h, [&](auto k) {
    int checked = 0;
    while (checked < 500) {
      const Vec3d r{u(rng), u(rng), u(rng)};
      const double len = norm(r);
      if (len >= 0.98 * h || len < 0.02 * h)
        continue;
      ++checked;
      const Vec3d g = k.grad(r, len), gm = k.grad(-r, len);
      EXPECT_NEAR(g.x, -gm.x, 1e-12 * (1 + std::fabs(g.x)));
      EXPECT_NEAR(g.y, -gm.y, 1e-12 * (1 + std::fabs(g.y)));
      EXPECT_NEAR(g.z, -gm.z, 1e-12 * (1 + std::fabs(g.z)));
      // Central differences of W(|r|) in each direction.
      const double e = 1e-6 * h;
      auto W = [&](const Vec3d& p) { return k.W(norm(p)); };
      const Vec3d fd{(W(r + Vec3d{e, 0, 0}) - W(r - Vec3d{e, 0, 0})) / (2 * e),
                     (W(r + Vec3d{0, e, 0}) - W(r - Vec3d{0, e, 0})) / (2 * e),
                     (W(r + Vec3d{0, 0, e}) - W(r - Vec3d{0, 0, e})) / (2 * e)};
      const double scale = norm(g) + 1e-3 * k.W(0) / h;
      EXPECT_LT(norm(fd - g), 1e-5 * scale) << "at r = " << len / h << " h";
    }
    return 0;
  });
}

TEST_P(KernelTest, FloatAgreesWithDouble) {
  const double h = 0.02;
  with_kernel<double>(GetParam(), h, [&](auto kd) {
    with_kernel<float>(GetParam(), static_cast<float>(h), [&](auto kf_) {
      for (int i = 0; i < 100; ++i) {
        const double r = h * i / 100.0;
        EXPECT_NEAR(kf_.W(static_cast<float>(r)), kd.W(r), 1e-5 * kd.W(0));
      }
      return 0;
    });
    return 0;
  });
}

TEST_P(KernelTest, LatticeMassGivesRestDensityInTheInterior) {
  for (double support : {1.5, 2.0, 3.0}) {
    const double dp = 0.01, rho0 = 1000;
    const double m = lattice_particle_mass(GetParam(), support, dp, rho0);
    // Independent evaluation: density at a lattice node from all nodes within the support.
    double rho = 0;
    with_kernel<double>(GetParam(), support * dp, [&](auto k) {
      const int r = 5;
      for (int i = -r; i <= r; ++i)
        for (int j = -r; j <= r; ++j)
          for (int l = -r; l <= r; ++l)
            rho += m * k.W(dp * std::sqrt(double(i * i + j * j + l * l)));
      return 0;
    });
    EXPECT_NEAR(rho, rho0, 1e-9 * rho0);
    // With a wide support the lattice sum approximates the integral, so m -> rho0 dp^3. (With a
    // narrow one the peaked spiky kernel is dominated by W(0): m is 0.58 rho0 dp^3 at 1.5 dp.)
    if (support >= 3.0) {
      EXPECT_NEAR(m / (rho0 * dp * dp * dp), 1.0, 0.1) << "support " << support;
    }
  }
}

INSTANTIATE_TEST_SUITE_P(AllKernels, KernelTest,
                         ::testing::Values(KernelType::Spiky, KernelType::CubicSpline,
                                           KernelType::WendlandC2),
                         [](const auto& info) {
                           switch (info.param) {
                           case KernelType::Spiky:
                             return std::string("Spiky");
                           case KernelType::CubicSpline:
                             return std::string("CubicSpline");
                           default:
                             return std::string("WendlandC2");
                           }
                         });
