#pragma once
// Knit-fluid coupling (paper §5): DEM contact (Eq. 7, 8) and the capillary pressure of the
// porous knit (Eq. 9-12), as gather evaluators used by both backends. One pair function gives
// the force on a fluid particle from a knit point; the fluid side adds it, the knit side
// subtracts it, so the pair forces cancel bit for bit and momentum is conserved to rounding.
#include "core/Math.hpp"
#include "kernels/contact/DemContact_K.hpp"
#include "kernels/exec/Algorithms.hpp"
#include "kernels/grid/GridGeometry.hpp"
#include "kernels/grid/NeighbourList.hpp"
#include "kernels/particles/FluidSet.hpp"
#include "kernels/particles/KnitSet.hpp"

#include <cstdint>

namespace kf {

template <typename T>
struct CouplingParams {
  bool contact = false;        // DEM between fluid and knit (module "contact")
  bool capillary = false;      // Eq. 9-12 (module "capillary")
  bool capillary_force = true; // Eq. 12 on the fluid (the paper's model; off when conserving)
  T reach = T(0);              // R_fluid + R_knit: contact distance
  DemMaterial<T> dem;
  T h = T(0);               // kernel support of the capillary terms (the fluid's)
  T porosity = T(1);        // phi
  T rho0 = T(1000);         // fluid rest density
  T pressure_scale = T(0);  // sigma / sqrt(kappa / phi) [Pa]: P = scale J(s) (Eq. 10)
  T volume_per_mass = T(0); // V_i = m_i * volume_per_mass (thickness / mass per area)
  Vec3<T> gravity{T(0), T(0), T(0)};
};

/// The farthest a pair interacts: the contact reach, or the kernel support where capillary.
template <typename T>
KF_HD KF_INLINE T coupling_reach(const CouplingParams<T>& prm) {
  return prm.capillary && prm.h > prm.reach ? prm.h : prm.reach;
}

/// Leverett J for a hydrophilic medium (Eq. 11): positive below saturation, zero at s = 1,
/// negative above (oversaturated knit pushes fluid out).
template <typename T>
KF_HD KF_INLINE T leverett_j(T s) {
  const T u = T(1) - s;
  return u * (T(1.417) + u * (T(-2.120) + u * T(1.263)));
}

/// Per knit point: the fluid density the kernel sees there, rho~ = sum_j m_j W, gives the fluid
/// mass in its volume m_fluid = V rho~, the saturation s = m_fluid / (phi V rho0) (Eq. 9) and
/// the capillary pressure P = sigma J(s) / sqrt(kappa / phi) (Eq. 10).
template <typename T, typename K>
struct SaturationEvaluator {
  K kernel;
  CouplingParams<T> prm;
  const Vec3<T>* knit_x;
  const T* knit_m;
  const Vec3<T>* fluid_x;
  const T* fluid_m;
  CellView<T> fluid_cells;
  const std::uint8_t* fluid_near; // FluidSide::near
  T* saturation;
  T* pressure;
  T* fluid_mass;

  /// g: the lanes sharing point i (for_each_lanes), as the knit side's pass: one lane's walk
  /// over the 27 cells of a wet point was the pass's latency (44 us on the pour, H200).
  KF_HD void operator()(std::size_t i, exec::Lanes g = {}) const {
    const Vec3<T> xi = knit_x[i];
    const T h2 = kernel.h * kernel.h;
    T rho = T(0);
    if (fluid_cells.may_find(fluid_near, xi))
      fluid_cells.for_each_candidate(xi, g.lane, g.size, [&](std::uint32_t j) {
        const T r2 = norm2(xi - fluid_x[j]);
        if (r2 < h2)
          rho += fluid_m[j] * kernel.W(ksqrt(r2));
      });
    rho = g.sum(rho);
    if (g.lane != 0)
      return;
    const T s = rho / (prm.porosity * prm.rho0);
    saturation[i] = s;
    pressure[i] = prm.pressure_scale * leverett_j(s);
    fluid_mass[i] = knit_m[i] * prm.volume_per_mass * rho;
  }
};

/// What a knit point brings to a pair: position, velocity, mass, capillary pressure.
template <typename T>
struct KnitPairSide {
  Vec3<T> x, v;
  T m, p;
};

/// Force on fluid particle j (x, v, m, rho) from knit point i: the DEM contact and the capillary
/// force V_j V_i P_i grad_{x_j} W(x_j - x_i) (Eq. 12 with the volumes that make it a force; it
/// points toward a knit point with P > 0, i.e. a drier one).
template <typename T, typename K>
KF_HD KF_INLINE bool coupling_pair_force(const K& kernel, const CouplingParams<T>& prm,
                                         const Vec3<T>& xj, const Vec3<T>& vj, T mj, T rhoj,
                                         const KnitPairSide<T>& i, Vec3<T>& f) {
  const Vec3<T> d = xj - i.x;
  const T r2 = norm2(d);
  const T reach = coupling_reach(prm);
  if (r2 >= reach * reach || r2 <= T(0))
    return false;
  f = Vec3<T>{T(0), T(0), T(0)};
  bool any = false;
  if (prm.contact) {
    Vec3<T> fc;
    if (dem_pair_force(d, vj - i.v, mj, i.m, prm.reach, prm.dem, fc)) {
      f += fc;
      any = true;
    }
  }
  if (prm.capillary && prm.capillary_force && r2 < kernel.h * kernel.h && i.p != T(0)) {
    const T vol_i = i.m * prm.volume_per_mass, vol_j = mj / rhoj;
    f += kernel.grad(d, ksqrt(r2)) * (vol_j * vol_i * i.p);
    any = true;
  }
  return any;
}

/// The knit points in the coupling grid's order (copies gathered through its permutation).
template <typename T>
struct SortedKnitSide {
  const Vec3<T>* x;
  const Vec3<T>* v;
  const T* m;
  const T* p;
};

/// Fluid side: impulse_j += weight * (sum over knit points of the pair force on j), for the fluid
/// particles flagged near the knit (a knit point in their 27 knit-grid cells), over the knit
/// points listed for j once per step (or its knit-grid cells where its list overflowed). When
/// the watched knit motion since the grid's sort passed its skin (*moved2 > skin2: the lists may
/// miss a pair) but not the cells' margin (walk2 = (cell - reach)^2: a point within the reach
/// now was within a cell edge of j where the grid sorted it), j walks its 27 cells, and the
/// flags still skip exactly the particles with no knit point within reach. Past the margin
/// (the grid and flags may miss a point) every fluid particle sums over all knit points: exact,
/// O(n m). The walk's tier matters: the pour's splash outruns the expected motion often enough
/// that the O(n m) sums were a third of this pass's time (docs/PERFORMANCE.md, P10 stage 8).
/// Lanes a fluid particle in the coupling's fluid-side passes (its knit list's build, its pair
/// forces, the absorption's choice): with a knit finer than the fluid a particle meets hundreds
/// of knit points (a 0.01 m fluid over 128 stitches, a 1.25 mm wicking strip), and one lane's walk
/// over them took 200-350 us a pass on an H200 while the knit's side took 20 (docs/PERFORMANCE.md).
/// 16, not 8, since P10 stage 7: the paper's pour whole 3% faster (the lists' 96 slots in 6
/// rounds a lane, not 12; late in the pour few fluid particles are left to fill the GPU).
inline constexpr unsigned kFluidSideLanes = 16;

template <typename T, typename K>
struct FluidCouplingEvaluator {
  K kernel;
  CouplingParams<T> prm;
  FluidView<T> f;
  SortedKnitSide<T> knit;
  CellView<T> knit_cells;
  T weight;
  Vec3<T>* impulse;
  const std::uint32_t* near;   // per fluid particle: 1 near the knit at the grid's sort
  const std::uint32_t* row_of; // per near fluid particle: its row of `list` (past its rows: none)
  ListView<T> list;            // per row: knit points (grid order) within reach + skin
  const T* moved2;
  T skin2;
  T walk2; // (cell - reach)^2: the grid's cells and the near flags hold up to this motion
  std::uint32_t n_knit;
  Vec3<T>* pair_force; // per slot of `list`: the pair's force on j (zero out of reach), kept for
                       // the knit side of the same substep

  /// g: the lanes sharing particle j (for_each_lanes): a coarse fluid's particle may meet
  /// hundreds of a fine knit's points, and one lane's walk over them was the pass's latency.
  KF_HD void operator()(std::size_t j, exec::Lanes g = {}) const {
    const T m2 = *moved2;
    const bool listed = m2 <= skin2; // NaN: neither
    const bool walked = m2 <= walk2;
    // The row read beside the flag, not after it: a near particle's walk waits on one load, not
    // on two in a row (every index of the fluid has a word of row_of).
    const std::uint32_t nj = near[j], rj = row_of[j];
    if (walked && !nj)
      return;
    const Vec3<T> xj = f.x[j], vj = f.v[j];
    const T mj = f.m[j], rhoj = f.rho[j];
    Vec3<T> sum{T(0), T(0), T(0)};
    auto force = [&](std::uint32_t i, Vec3<T>& fij) {
      return coupling_pair_force(kernel, prm, xj, vj, mj, rhoj,
                                 KnitPairSide<T>{knit.x[i], knit.v[i], knit.m[i], knit.p[i]}, fij);
    };
    auto pair = [&](std::uint32_t i) {
      Vec3<T> fij;
      if (force(i, fij))
        sum += fij;
    };
    if (listed && nj && rj < list.rows && list.complete(rj))
      list.for_each_slot(rj, g.lane, g.size, [&](std::size_t s, std::uint32_t i) {
        Vec3<T> fij{T(0), T(0), T(0)};
        if (force(i, fij))
          sum += fij;
        pair_force[s] = fij;
      });
    else if (walked)
      knit_cells.for_each_candidate(xj, g.lane, g.size, pair);
    else
      for (std::uint32_t i = g.lane; i < n_knit; i += g.size)
        pair(i);
    sum = g.sum(sum);
    if (g.lane == 0)
      impulse[j] += sum * weight;
  }
};

/// Knit side: a_i += (weight of its absorbed fluid - sum over fluid particles of the pair force
/// on them) / m_i, for free points: the forces the fluid side kept for the pairs its lists hold
/// (those lists transposed: the fluid particles in ascending order), or computed again over
/// the point's fluid-grid cells where the lists may miss a pair (the knit moved past the watch's
/// skin, a fluid row or the point's own overflowed).
template <typename T, typename K>
struct KnitCouplingEvaluator {
  K kernel;
  CouplingParams<T> prm;
  KnitView<T> p;
  const T* pressure;
  const T* fluid_mass; // nullptr: no weight of absorbed fluid
  const Vec3<T>* fluid_x;
  const Vec3<T>* fluid_v;
  const T* fluid_m;
  const T* fluid_rho;
  CellView<T> fluid_cells;
  const std::uint8_t* fluid_near; // FluidSide::near
  ListView<T> rows;               // per knit point: its pairs' slots (TransposedList)
  const std::uint32_t* rows_incomplete;
  const Vec3<T>* pair_force; // the fluid side's, per slot of its lists
  const T* moved2;
  T skin2;

  KF_HD void operator()(std::size_t i, exec::Lanes g = {}) const {
    if (p.handle[i] != kFreePoint)
      return;
    const Vec3<T> f = force(i, g);
    if (g.lane == 0)
      p.a[i] += f * (T(1) / p.m[i]);
  }

  /// The fluid's force on free point i (and its absorbed fluid's weight), summed over the
  /// group's lanes (KnitPointForces).
  KF_HD KF_INLINE Vec3<T> force(std::size_t i, exec::Lanes g) const {
    Vec3<T> force = held_force(i, g);
    if (fluid_mass)
      force += prm.gravity * fluid_mass[i];
    return force;
  }

  /// The fluid's push on point i alone, for a handle's point (KnitPointForces::held): the
  /// weight of its absorbed fluid is the handle's to hold, and moves no energy the run counts.
  KF_HD KF_INLINE Vec3<T> held_force(std::size_t i, exec::Lanes g) const {
    const KnitPairSide<T> side{p.x[i], p.v[i], p.m[i], pressure[i]};
    Vec3<T> sum{T(0), T(0), T(0)};
    auto pair = [&](std::uint32_t j) {
      Vec3<T> fji;
      if (coupling_pair_force(kernel, prm, fluid_x[j], fluid_v[j], fluid_m[j], fluid_rho[j], side,
                              fji))
        sum += fji;
    };
    // The same decisions for the group's lanes (they read the point's words only).
    if (*moved2 <= skin2 && *rows_incomplete == 0u && rows.complete(i))
      rows.for_each_neighbour(i, side.x, g.lane, g.size,
                              [&](std::uint32_t s) { sum += pair_force[s]; });
    else if (fluid_cells.may_find(fluid_near, side.x))
      fluid_cells.for_each_candidate(side.x, g.lane, g.size, pair);
    return g.sum(sum) * T(-1);
  }
};

} // namespace kf
