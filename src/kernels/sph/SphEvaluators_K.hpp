#pragma once
#include "core/Math.hpp"
// The SPH evaluators: one particle's gather over its neighbours, as host-device functors.
// Gather only (each particle sums what acts on it): no atomics, deterministic sums.
#include "kernels/sph/SphNeighbours_K.hpp"

namespace kf {

// N: where a particle's neighbours come from (SphNeighbours_K.hpp): SphCellWalk (the grids'
// candidates) or SphList (lists); both meet the neighbours in the same order, so sums agree.
template <typename T, typename K, typename N>
struct DensityEvaluator {
  K kernel;
  Eos<T> eos;
  FluidView<T> f;
  N nb;
  BoundaryNeighbours<T> b;

  KF_HD void operator()(std::size_t i) const {
    const Vec3<T> xi = f.x[i];
    const T h2 = kernel.h * kernel.h;
    T rho = T(0), vol = T(0);
    nb.for_each_neighbour(
        i, xi,
        [&](std::uint32_t j) {
          const Vec4<T> xmj = f.xm[j];
          const T r2 = norm2(xi - xmj.xyz());
          if (r2 < h2)
            rho += xmj.w * kernel.W(ksqrt(r2));
        },
        [&](std::uint32_t k) {
          const T r2 = norm2(xi - b.x[k]);
          if (r2 < h2)
            vol += b.volume[k] * kernel.W(ksqrt(r2));
        });
    rho += eos.rho0 * vol; // psi_b = rho0 V_b
    const T p = eos.pressure(rho);
    f.rho[i] = rho;
    f.p[i] = p;
    // The forces pass's neighbour copies: (v, m P / rho^2) and m / rho (rho > 0: the i term).
    const T inv_rho = krcp(rho), m = f.m[i];
    const Vec3<T> v = f.v[i];
    f.vp[i] = {v.x, v.y, v.z, m * p * inv_rho * inv_rho};
    f.vol[i] = m * inv_rho;
  }
};

template <typename T, typename K>
struct BoundaryPressureEvaluator {
  K kernel;
  SphParams<T> prm;
  BoundaryView<T> b;
  FluidView<T> f;
  CellView<T> cells;
  const RigidShape<T>* shapes;

  KF_HD void operator()(std::size_t k) const {
    const Vec3<T> xb = b.x[k];
    const T h2 = kernel.h * kernel.h;
    T sum_w = T(0), sum_p = T(0);
    Vec3<T> sum_rho_r{T(0), T(0), T(0)}, sum_v{T(0), T(0), T(0)};
    cells.for_each_candidate(xb, [&](std::uint32_t j) {
      const Vec3<T> r = xb - f.x[j];
      const T r2 = norm2(r);
      if (r2 >= h2)
        return;
      const T w = kernel.W(ksqrt(r2));
      sum_w += w;
      sum_p += f.p[j] * w;
      sum_rho_r += r * (f.rho[j] * w);
      sum_v += f.v[j] * w;
    });
    T p = T(0);
    if (sum_w > T(0))
      p = (sum_p + dot(prm.gravity, sum_rho_r)) / sum_w;
    if (p < T(0))
      p = T(0); // a wall never pulls the fluid
    b.p[k] = p;
    b.rho[k] = prm.eos.density(p);
    if (prm.no_slip) {
      const std::uint32_t o = b.obstacle[k];
      const Vec3<T> vw = o == kWallObstacle ? Vec3<T>{T(0), T(0), T(0)} : shapes[o].velocity;
      b.v[k] = sum_w > T(0) ? vw * T(2) - sum_v * (T(1) / sum_w) : vw;
    }
  }
};

template <typename T, typename K, typename N>
struct ForceEvaluator {
  K kernel;
  SphParams<T> prm;
  FluidView<T> f;
  N nb;
  BoundaryNeighbours<T> b;

  // On the GPU the lanes of a warp walk their candidates together and ~85% of candidates are
  // out of range, so whenever one lane has a neighbour the whole warp runs the pair code: its
  // cost is paid per candidate. It is written with one reciprocal square root and two
  // reciprocals (no divisions): grad W = r_ij dW/dr / r, and r . grad W = r^2 dW/dr / r.
  KF_HD void operator()(std::size_t i) const {
    const Vec3<T> xi = f.x[i];
    const Vec3<T> vi = f.v[i];
    const T h2 = kernel.h * kernel.h;
    const T eta2 = T(0.01) * h2; // keeps the viscous term finite as r -> 0 (Morris et al. 1997)
    const T inv_rho_i = krcp(f.rho[i]);
    const T pi = f.p[i] * inv_rho_i * inv_rho_i;
    const T mu2 = T(2) * prm.viscosity;
    Vec3<T> acc = prm.gravity;
    // Boundary particles act as fluid particles of mass psi_b = rho0 V_b and pressure P_b. Both
    // sources meet every fluid neighbour before any boundary one, so the sums keep one order.
    const T rho0 = prm.eos.rho0;
    nb.for_each_neighbour(
        i, xi,
        [&](std::uint32_t j) {
          const Vec4<T> xmj = f.xm[j]; // (x_j, m_j)
          const Vec3<T> rij = xi - xmj.xyz();
          const T r2 = norm2(rij);
          if (r2 >= h2 || r2 <= T(0)) // r = 0: j == i (or a coincident particle: no direction)
            return;
          const T inv_r = krsqrt(r2);
          const T dw = kernel.dWdr(r2 * inv_r) * inv_r; // grad W = rij dw
          const Vec4<T> vpj = f.vp[j];                  // (v_j, m_j P_j / rho_j^2)
          // Eq. 3: pressure, symmetric in i and j so pair forces cancel.
          const T press = xmj.w * pi + vpj.w;
          // Eq. 4 (Morris form): mu_i + mu_j, relative velocity, (r . grad W) / (r^2 + eta^2),
          // with m_j / rho_j from the density pass.
          const T visc = mu2 * inv_rho_i * f.vol[j] * (r2 * dw) * krcp(r2 + eta2);
          acc += (vi - vpj.xyz()) * visc - rij * (dw * press);
        },
        [&](std::uint32_t k) {
          const Vec3<T> rik = xi - b.x[k];
          const T r2 = norm2(rik);
          if (r2 >= h2 || r2 <= T(0))
            return;
          const T inv_r = krsqrt(r2);
          const T dw = kernel.dWdr(r2 * inv_r) * inv_r;
          const T inv_rho_k = krcp(b.rho[k]);
          const T mk = rho0 * b.volume[k];
          acc -= rik * (dw * mk * (pi + b.p[k] * inv_rho_k * inv_rho_k));
          if (b.v)
            acc += (vi - b.v[k]) * (mk * mu2 * inv_rho_i * inv_rho_k * (r2 * dw) * krcp(r2 + eta2));
        });
    f.a[i] = acc;
  }
};

} // namespace kf
