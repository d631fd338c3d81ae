#pragma once
// The mass-conserving absorption model (beyond the paper; docs/PHYSICS.md): fluid particles
// that touch the fabric are absorbed into its points, the absorbed fluid moves between
// neighbouring points by Darcy's law under capillary suction and gravity, and points holding
// more than they can emit drops. Every transfer is written once per pair or per particle, so
// free + absorbed mass is conserved to rounding.
#include "core/Math.hpp"
#include "kernels/coupling/Coupling_K.hpp"
#include "kernels/grid/GridGeometry.hpp"

#include <cstdint>

namespace kf {

inline constexpr std::uint32_t kNoTarget = 0xFFFFFFFFu;

template <typename T>
struct AbsorptionParams {
  T reach = T(0);             // a fluid particle this close to a knit point is absorbed
  T emit_saturation = T(1);   // a point emits a drop once it holds this much plus the drop
  T drop_mass = T(0);         // largest emitted particle (the fluid's lattice mass)
  T min_particle_mass = T(0); // a particle left lighter than this by absorption is taken whole
  T drop_offset = T(0);       // how far below the point the drop appears
  Vec3<T> down{T(0), T(0), T(-1)};
  Vec3<T> gravity{T(0), T(0), T(-9.81)};
  T rho0 = T(1000);
  T pressure_scale = T(0); // sigma / sqrt(kappa / phi)
};

/// Capacity of a knit point: the fluid its pores hold, phi V rho0.
template <typename T>
KF_HD KF_INLINE T pore_capacity(T dry_mass, T volume_per_mass, T porosity, T rho0) {
  return porosity * dry_mass * volume_per_mass * rho0;
}

/// Fluid side: the nearest knit point within reach that is not yet saturated (knit index), or
/// kNoTarget.
template <typename T>
struct AbsorbTargetEvaluator {
  const Vec3<T>* fluid_x;
  const Vec3<T>* knit_x_sorted;
  const T* knit_s_sorted;
  const std::uint32_t* knit_index; // sorted position -> knit index (the grid's permutation)
  const std::uint64_t* knit_id;    // knit index -> global id (mesh index)
  CellView<T> knit_cells;
  T reach;
  std::uint32_t* target;

  /// g: the lanes sharing particle j (for_each_lanes, kFluidSideLanes); each takes every
  /// g.size-th candidate, then the group keeps the nearest, the lowest id among equals: the
  /// choice one lane makes over them all.
  KF_HD void operator()(std::size_t j, exec::Lanes g = {}) const {
    const Vec3<T> xj = fluid_x[j];
    T best = reach * reach;
    std::uint32_t pick = kNoTarget;
    knit_cells.for_each_candidate(xj, g.lane, g.size, [&](std::uint32_t k) {
      const T r2 = norm2(xj - knit_x_sorted[k]);
      // Ties go to the lower id, so the choice depends neither on the grid's order nor on where
      // a rank keeps the point.
      if (knit_s_sorted[k] < T(1) && (r2 < best || (r2 == best && pick != kNoTarget &&
                                                    knit_id[knit_index[k]] < knit_id[pick]))) {
        best = r2;
        pick = knit_index[k];
      }
    });
    if (g.size > 1) {
      const T nearest = g.reduce(best, [](T a, T b) { return b < a ? b : a; });
      const bool mine = pick != kNoTarget && best == nearest;
      const std::uint64_t id = mine ? knit_id[pick] : ~std::uint64_t(0);
      const std::uint64_t lowest =
          g.reduce(id, [](std::uint64_t a, std::uint64_t b) { return b < a ? b : a; });
      const unsigned from = g.first_set(mine && id == lowest);
      pick = from < g.size ? static_cast<std::uint32_t>(g.broadcast(static_cast<int>(pick), from))
                           : kNoTarget;
    }
    if (g.lane == 0)
      target[j] = pick;
  }
};

/// The mass particle j (mass m) gives the knit point it chose, which takes the fraction f of
/// every offer (f = room / demand, at most 1): all of it when f = 1 or when what would be left is
/// below m_min (the particle is then removed). The knit side and the fluid side evaluate this
/// same expression, so what one gains the other loses exactly.
template <typename T>
KF_HD KF_INLINE T absorbed_amount(T f, T m, T m_min) {
  const T part = f * m;
  return (f >= T(1) || m - part < m_min) ? m : part;
}

/// Knit side, pass 1: the fraction of the offers it can take, f = min(1, room / demand), with
/// room = capacity - absorbed (fills to s = 1).
template <typename T>
struct AbsorbFractionEvaluator {
  const Vec3<T>* knit_x;
  const T* absorbed;
  const T* capacity;
  const T* fluid_m;
  const std::uint32_t* target;
  CellView<T> fluid_cells;
  T* fraction;

  KF_HD void operator()(std::size_t i) const {
    T demand = T(0);
    fluid_cells.for_each_candidate(knit_x[i], [&](std::uint32_t j) {
      if (target[j] == static_cast<std::uint32_t>(i))
        demand += fluid_m[j];
    });
    const T room = capacity[i] - absorbed[i];
    fraction[i] = demand > T(0) && room > T(0) ? (room >= demand ? T(1) : room / demand) : T(0);
  }
};

/// Knit side, pass 2: takes in what the particles that chose it give; mass and momentum carried.
template <typename T>
struct AbsorbGatherEvaluator {
  KnitView<T> p;
  const T* dry_mass;
  T* absorbed;
  const T* fraction;
  const Vec3<T>* fluid_x;
  const Vec3<T>* fluid_v;
  const T* fluid_m;
  const std::uint32_t* target;
  CellView<T> fluid_cells;
  T m_min;

  KF_HD void operator()(std::size_t i) const {
    const T f = fraction[i];
    if (f <= T(0))
      return;
    T dm = T(0);
    Vec3<T> dp{T(0), T(0), T(0)};
    fluid_cells.for_each_candidate(p.x[i], [&](std::uint32_t j) {
      if (target[j] == static_cast<std::uint32_t>(i)) {
        const T give = absorbed_amount(f, fluid_m[j], m_min);
        dm += give;
        dp += fluid_v[j] * give;
      }
    });
    const T m_old = p.m[i];
    absorbed[i] += dm;
    const T m_new = dry_mass[i] + absorbed[i];
    if (p.handle[i] == kFreePoint)
      p.v[i] = (p.v[i] * m_old + dp) * (T(1) / m_new);
    p.m[i] = m_new;
  }
};

/// Darcy flux into point i along one pore link from j: conductance K (rho0 kappa / mu times the
/// link's cross-section over its length) times the upwind relative permeability s^3 times the
/// drop in potential Phi = -P_c(s) - rho0 g.x; at most half of what the upwind point holds over
/// its links, so no point goes negative. Antisymmetric: flux(i <- j) = -flux(j <- i) bit for bit.
template <typename T>
KF_HD KF_INLINE T darcy_flux(T K, T phi_i, T phi_j, T s_i, T s_j, T m_i, T m_j, T deg_i, T deg_j,
                             T dt) {
  const bool from_j = phi_j > phi_i;
  const T s_up = from_j ? s_j : s_i;
  const T kr = s_up <= T(0) ? T(0) : (s_up >= T(1) ? T(1) : s_up * s_up * s_up);
  T q = K * kr * (phi_j - phi_i) * dt; // mass into i over dt
  const T cap = from_j ? m_j / (T(2) * deg_j) : m_i / (T(2) * deg_i);
  if (q > cap)
    q = cap;
  if (q < -cap)
    q = -cap;
  return q;
}

/// Potential of the absorbed fluid at a point (saturation clamped to 1.5 so an overfilled
/// point pushes out firmly but not stiffly).
template <typename T>
KF_HD KF_INLINE T pore_potential(T s, const Vec3<T>& x, const AbsorptionParams<T>& prm) {
  const T sc = s > T(1.5) ? T(1.5) : s;
  return -prm.pressure_scale * leverett_j(sc) - prm.rho0 * dot(prm.gravity, x);
}

/// Each point's links (compressed rows; on N ranks only the owned points have rows, their other
/// ends owned or ghosts) and every point's number of links in the whole knit.
template <typename T>
struct PoreLinksView {
  const std::uint32_t* start;
  const std::uint32_t* other;
  const T* conductance;
  const T* degree;
};

/// Each point's net inflow over dt and the momentum it carries (the donor's velocity), so moving
/// fluid between points that move differently keeps the total momentum.
template <typename T>
struct DiffusionEvaluator {
  PoreLinksView<T> links;
  const Vec3<T>* x;
  const Vec3<T>* v;
  const T* absorbed;
  const T* capacity;
  AbsorptionParams<T> prm;
  T dt;
  T* delta;
  Vec3<T>* delta_momentum;

  KF_HD void operator()(std::size_t i) const {
    const T si = absorbed[i] / capacity[i];
    const T phi_i = pore_potential(si, x[i], prm);
    const std::uint32_t b = links.start[i], e = links.start[i + 1];
    const T deg_i = links.degree[i];
    T sum = T(0);
    Vec3<T> mom{T(0), T(0), T(0)};
    for (std::uint32_t l = b; l < e; ++l) {
      const std::uint32_t j = links.other[l];
      const T sj = absorbed[j] / capacity[j];
      const T deg_j = links.degree[j];
      const T q = darcy_flux(links.conductance[l], phi_i, pore_potential(sj, x[j], prm), si, sj,
                             absorbed[i], absorbed[j], deg_i, deg_j, dt);
      sum += q;
      mom += (q > T(0) ? v[j] : v[i]) * q;
    }
    delta[i] = sum;
    delta_momentum[i] = mom;
  }
};

} // namespace kf
