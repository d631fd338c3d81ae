#pragma once
// A jittered block of water (random velocities, optionally random densities) on a two-layer
// floor, sorted into a grid with the pass's copies written: what a test of one SPH pass over it
// needs (test_shifting_K, test_artificial_viscosity_K).
#include "kernels/exec/Backend.hpp"
#include "kernels/grid/NeighbourGrid.hpp"
#include "kernels/particles/FluidSet.hpp"
#include "kernels/sph/Sph.hpp"

#include <cmath>
#include <random>

namespace kf::test {

constexpr double kDp = 0.01, kH = 2 * kDp, kSkin = 0.2 * kH;
const Vec3d kLo{0, 0, -0.03}, kHi{0.16, 0.1, 0.1}; // the grid's box

/// A jittered block of water on a two-layer floor, and what a pass over it needs.
template <typename T>
struct FluidBlock {
  exec::Exec ex;
  FluidSet<T> f;
  BoundarySet<T> b;
  NeighbourGrid<T> grid, bgrid; // the fluid's, the floor's (the same cells)
  SphParams<T> prm;
  std::size_t n = 0, nb = 0;

  /// Positions jittered by up to jitter x dp / 2 an axis, densities 1000 (1 +- rho_spread / 2).
  FluidBlock(exec::Backend backend, double jitter, unsigned seed, double rho_spread = 0)
      : ex{backend}, f(backend), b(backend),
        grid(backend, NeighbourGrid<T>::cover(kLo, kHi, kH + kSkin)),
        bgrid(backend, NeighbourGrid<T>::cover(kLo, kHi, kH + kSkin)) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(-0.5, 0.5), speed(0.5, 1.5);
    std::vector<Vec3<T>> xf, xb, v;
    for (double z = 0.5 * kDp; z < 0.08; z += kDp)
      for (double y = 0.5 * kDp; y < kHi.y; y += kDp)
        for (double x = 0.5 * kDp; x < 0.12; x += kDp) {
          xf.push_back(vec_cast<T>(Vec3d{x + jitter * kDp * u(rng), y + jitter * kDp * u(rng),
                                         z + jitter * kDp * u(rng)}));
          Vec3d d{u(rng), u(rng), u(rng)};
          v.push_back(vec_cast<T>(d * (speed(rng) / std::sqrt(norm2(d)))));
        }
    for (double z = -0.5 * kDp; z > -2 * kDp; z -= kDp)
      for (double y = 0.5 * kDp; y < kHi.y; y += kDp)
        for (double x = 0.5 * kDp; x < 0.15; x += kDp)
          xb.push_back(vec_cast<T>(Vec3d{x, y, z}));
    n = xf.size();
    nb = xb.size();
    f.resize(n);
    f.x.assign(xf);
    f.v.assign(v);
    f.m.assign(std::vector<T>(n, T(1000 * kDp * kDp * kDp)));
    std::vector<T> rho(n);
    for (auto& r : rho)
      r = T(1000 * (1 + rho_spread * u(rng)));
    f.rho.assign(rho);
    f.drho.assign(std::vector<T>(n, T(0)));
    f.drho_prev.assign(std::vector<T>(n, T(0)));
    b.resize(nb);
    b.x.assign(xb);
    b.obstacle.assign(std::vector<std::uint32_t>(nb, kWallObstacle));
    b.volume.assign(std::vector<T>(nb, T(kDp * kDp * kDp)));
    prm.kernel = KernelType::CubicSpline;
    prm.h = T(kH);
    bgrid.build(ex, b.x.data(), nb);
    b.reorder(ex, bgrid.permutation());
    sort();
  }
  /// The grid and the pass's copies (xm, p, vp, vol = m / rho) at the current positions.
  void sort() {
    grid.build(ex, f.x.data(), n);
    f.reorder(ex, grid.permutation());
    sph_density_predict(ex, prm, f.view(), T(0));
  }
  BoundaryNeighbours<T> walls() {
    return {b.x.data(), b.volume.data(), nullptr, nullptr, nullptr, false, bgrid.view(), nb};
  }
};

} // namespace kf::test
