// Monaghan's artificial viscosity (SphParams::artificial, the forces pass's Artificial case): the
// acceleration it adds must be -sum_j m_j Pi_ij grad W_ij over approaching fluid pairs, computed
// here by brute force over all pairs in double; it must keep the momentum (pairwise antisymmetric)
// and only take kinetic energy away. With it off the pass is the one without it, bit for bit.
// CPU and GPU.
#include "kernels/sph/SmoothingKernels.hpp"

#include "support/Bits.hpp"
#include "support/FluidBlock.hpp"

#include <gtest/gtest.h>

namespace kf {
namespace {

using test::kDp;
using test::kH;

template <typename T>
std::vector<Vec3<T>> accelerations(test::FluidBlock<T>& blk, T artificial) {
  blk.prm.artificial = artificial;
  blk.f.a.poison(); // NaN: an unwritten row shows
  sph_forces(blk.ex, blk.prm, blk.f.view(), blk.grid.view(), BoundaryNeighbours<T>{});
  return blk.f.a.to_host();
}

template <typename T>
void check(exec::Backend backend) {
  test::FluidBlock<T> blk(backend, 0.3, 7, 0.04); // densities 1000 +- 2%
  blk.prm.viscosity = T(0.01);
  const double alpha = 0.05, c0 = 20;
  const auto without = accelerations(blk, T(0));
  const auto with = accelerations(blk, T(alpha * c0));
  const auto x = blk.f.x.to_host(), v = blk.f.v.to_host();
  const auto rho = blk.f.rho.to_host(), m = blk.f.m.to_host();
  const auto k = CubicSplineKernel<double>(kH);
  const double eta2 = 0.01 * kH * kH;
  Vec3d momentum{0, 0, 0};
  double scale = 0, power = 0, largest = 0;
  std::size_t approached = 0;
  for (std::size_t i = 0; i < blk.n; ++i) {
    Vec3d want{0, 0, 0};
    for (std::size_t j = 0; j < blk.n; ++j) {
      const Vec3d r = vec_cast<double>(x[i]) - vec_cast<double>(x[j]);
      const double r2 = norm2(r);
      if (r2 >= kH * kH || r2 <= 0)
        continue;
      const double vr = dot(vec_cast<double>(v[i]) - vec_cast<double>(v[j]), r);
      if (vr >= 0)
        continue;
      ++approached;
      const double mu = 0.5 * kH * vr / (r2 + eta2);
      const double pi = -alpha * c0 * mu / (0.5 * (double(rho[i]) + double(rho[j])));
      const double dist = std::sqrt(r2);
      want = want - r * (double(m[j]) * pi * k.dWdr(dist) / dist);
    }
    const Vec3d got = vec_cast<double>(with[i]) - vec_cast<double>(without[i]);
    largest = std::max(largest, std::sqrt(norm2(want)));
    // The difference of two sums of ~35 pair terms (pressure, viscosity, the artificial term;
    // the pressures of +-2% densities ~1e3 m/s^2) against terms up to 106 m/s^2. Measured on the
    // CPU: float 2.3e-4, double 3.3e-13 m/s^2 at worst; the float bound leaves the GPU's fast
    // reciprocals room (10x).
    const double tol = std::is_same_v<T, float> ? 2e-3 : 1e-11;
    EXPECT_LE(std::sqrt(norm2(got - want)), tol) << "particle " << i;
    momentum = momentum + got * double(m[i]);
    scale += double(m[i]) * std::sqrt(norm2(got));
    power += double(m[i]) * dot(got, vec_cast<double>(v[i]));
  }
  EXPECT_GT(approached, blk.n); // the random velocities close many pairs
  EXPECT_GT(largest, 50.0);     // and the term is large against the tolerance above (106)
  // Pairwise antisymmetric: the momentum it adds is rounding of its magnitude (measured: float
  // 3.5e-8, double 6.4e-17 of it).
  EXPECT_LE(std::sqrt(norm2(momentum)), (std::is_same_v<T, float> ? 1e-6 : 1e-15) * scale);
  // Dissipative: sum_i m_i v_i . a_i = 1/2 sum_ij m_i m_j Pi_ij v_ij . grad W_ij <= 0.
  EXPECT_LT(power, 0.0);
  // Off, the pass is the one without the term.
  blk.prm.artificial = T(0);
  EXPECT_TRUE(test::same_bits(accelerations(blk, T(0)), without));
}

TEST(ArtificialViscosity, MatchesBruteForceCpuFloat) {
  check<float>(exec::Backend::Cpu);
}
TEST(ArtificialViscosity, MatchesBruteForceCpuDouble) {
  check<double>(exec::Backend::Cpu);
}
TEST(ArtificialViscosity, MatchesBruteForceCudaFloat) {
  if (!exec::cuda_available())
    GTEST_SKIP() << "no CUDA device";
  check<float>(exec::Backend::Cuda);
}

} // namespace
} // namespace kf
