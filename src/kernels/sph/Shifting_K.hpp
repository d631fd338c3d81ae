#pragma once
// Particle shifting (Lind et al. 2012; DualSPHysics's Fickian form) as host-device functors: one
// particle's concentration gradient and position divergence over its neighbours, and the move.
#include "core/Math.hpp"
#include "kernels/sph/SphNeighbours_K.hpp"

namespace kf {

/// The shift's settings (Scene::Solver::shifting_*), for a step of dt.
template <typename T>
struct ShiftRule {
  T coefficient = T(2); // A: the move is -A (h / 2) |v| dt grad C
  T surface = T(2.75);  // div r below this: the free surface, no move
  T dt = T(0);
};

/// Particle i's shift into shift[i]: -A (h / 2) |v_i| dt grad C_i (h / 2: DualSPHysics's
/// smoothing length, whose kernels reach 2 of it; ours reach h), grad C_i = sum_j V_j grad W_ij
/// over the fluid (V_j = m_j / rho_j, the density pass's copies) and boundary (V_b) neighbours,
/// none where div r_i = -sum_j V_j r_ij . grad W_ij < surface (a free surface's particles would be
/// pushed out of the water), and at most |v_i| dt long (so a step moves a particle at most twice
/// its advection: the "verlet" lists' bound). Reads xm and vol: after the density pass at the
/// same positions.
template <typename T, typename K, typename N>
struct ShiftEvaluator {
  K kernel;
  FluidView<T> f;
  N nb;
  BoundaryNeighbours<T> b;
  ShiftRule<T> rule;
  Vec3<T>* shift;

  KF_HD void operator()(std::size_t i) const {
    const Vec3<T> xi = f.x[i];
    const T h2 = kernel.h * kernel.h;
    Vec3<T> grad{T(0), T(0), T(0)};
    T div = T(0);
    auto add = [&](const Vec3<T>& rij, T vol) {
      const T r2 = norm2(rij);
      if (r2 >= h2 || r2 <= T(0)) // r = 0: i itself, no direction
        return;
      const T inv_r = krsqrt(r2);
      const T dw = kernel.dWdr(r2 * inv_r) * inv_r; // grad W = rij dw
      grad += rij * (vol * dw);
      div -= vol * r2 * dw;
    };
    nb.for_each_neighbour(
        i, xi, [&](std::uint32_t j) { add(xi - f.xm[j].xyz(), f.vol[j]); },
        [&](std::uint32_t k) { add(xi - b.x[k], b.volume[k]); });
    Vec3<T> s{T(0), T(0), T(0)};
    if (div >= rule.surface) {
      const T step = norm(f.v[i]) * rule.dt; // |v| dt
      s = grad * (-rule.coefficient * T(0.5) * kernel.h * step);
      const T len2 = norm2(s);
      if (len2 > step * step)
        s = s * (step * krsqrt(len2));
    }
    shift[i] = s;
  }
};

/// x_i += shift_i.
template <typename T>
struct ApplyShift {
  Vec3<T>* x;
  const Vec3<T>* shift;
  KF_HD void operator()(std::size_t i) const { x[i] += shift[i]; }
};

} // namespace kf
