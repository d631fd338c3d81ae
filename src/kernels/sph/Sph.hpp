#pragma once
// SPH fluid stages (paper §4): density (Eq. 2) with the EOS, and accelerations from pressure
// (Eq. 3), viscosity (Eq. 4) and gravity, with Akinci et al. 2012 boundary particles.
#include "core/SolverOptions.hpp"
#include "kernels/boundary/RigidShape.hpp"
#include "kernels/exec/Algorithms.hpp"
#include "kernels/grid/GridGeometry.hpp"
#include "kernels/grid/NeighbourList.hpp"
#include "kernels/particles/FluidSet.hpp"
#include "kernels/sph/Eos.hpp"

namespace kf {

template <typename T>
struct SphParams {
  KernelType kernel = KernelType::Spiky;
  T h = T(0.02); // support radius
  Eos<T> eos;
  T viscosity = T(1e-3); // dynamic viscosity mu
  bool no_slip = true;   // walls carry viscous stress (Eq. 4 with the wall particles' velocity)
  Vec3<T> gravity{T(0), T(0), T(-9.81)};
  DensityModel density = DensityModel::Summation;
  // Continuity: the delta-SPH diffusion coefficient delta h c0, with h the smoothing length (half
  // the support, DualSPHysics's h for its kernels of support 2h).
  T diffusion = T(0);
  // Monaghan's artificial viscosity between fluid particles: alpha c0 (0: none). It damps the
  // pressure noise of the summation density, which nothing else damps (docs/PHYSICS.md).
  T artificial = T(0);
};

/// Boundary particles seen by fluid kernels (empty when the scene has no boundary module).
template <typename T>
struct BoundaryNeighbours {
  const Vec3<T>* x = nullptr;  // positions: the grid's order, the lists' build
  const T* volume = nullptr;   // V (summation density: psi = rho0 V)
  const Vec4<T>* xv = nullptr; // the forces pass's gather copies (BoundaryView): (x, V),
  const Vec4<T>* vp = nullptr; // (v, P / rho^2) with the no-slip v,
  const T* inv_rho = nullptr;  // 1 / rho
  bool no_slip = false;        // walls carry viscous stress (vp's v); else free slip
  CellView<T> cells{};
  std::size_t n = 0;
  // Per linear cell of `cells`' geometry: 1 where boundary particles lie around (null: walk
  // every cell). Most fluid lies far from any wall; this saves its empty boundary-cell walks.
  const std::uint8_t* near = nullptr;
  // The solids' own velocity, which the continuity equation sees (the no-slip v above is a ghost
  // velocity for the viscous term only): shapes[obstacle[k]], walls at rest. Null: all at rest.
  const std::uint32_t* obstacle = nullptr;
  const RigidShape<T>* shapes = nullptr;

  KF_HD KF_INLINE Vec3<T> wall_velocity(std::uint32_t k) const {
    if (!shapes)
      return {T(0), T(0), T(0)};
    const std::uint32_t o = obstacle[k];
    return o == kWallObstacle ? Vec3<T>{T(0), T(0), T(0)} : shapes[o].velocity;
  }

  /// Whether the boundary loop from x can find anything.
  KF_HD KF_INLINE bool around(const Vec3<T>& x) const { return n > 0 && cells.may_find(near, x); }
};

/// rho_i (Eq. 2, plus boundary psi_b W) and P_i from the EOS, for every fluid particle, and the
/// gather copies the forces read (FluidView::xm, vp, vol). With a
/// `list` (SphLists; an empty view has no counts), neighbours come from it instead
/// of the grids.
template <typename T>
void sph_density(const exec::Exec& ex, const SphParams<T>& prm, FluidView<T> f, CellView<T> cells,
                 const BoundaryNeighbours<T>& b, const ListView<T>& list = {});
/// sph_density in parts, for a pass split around a halo exchange: the gather copies of position
/// and mass (xm) for every fluid particle, then the density of the particles `rows` names.
template <typename T>
void sph_pack(const exec::Exec& ex, FluidView<T> f);
template <typename T>
void sph_density_rows(const exec::Exec& ex, const SphParams<T>& prm, FluidView<T> f,
                      CellView<T> cells, const BoundaryNeighbours<T>& b, const ListView<T>& list,
                      const exec::Rows& rows);

/// Boundary pressure from the fluid around each boundary particle (Adami et al. 2012):
/// P_b = (sum_f P_f W + (g - a_b) . sum_f rho_f (x_b - x_f) W) / sum_f W, and rho_b from the EOS.
/// Static and constant-velocity solids have a_b = 0. With prm.no_slip it also sets the velocity
/// the viscous term sees, v_b = 2 v_wall - sum_f v_f W / sum_f W, so the fluid's velocity
/// extrapolates to the wall's at the wall surface. shapes[obstacle] gives v_wall (walls: 0).
/// Writes p and the forces pass's copies (BoundaryView::vp, inv_rho).
/// `fluid_near` (NeighbourGrid::occupied_around of the fluid grid, or null): a boundary particle
/// whose cell has no fluid candidate around skips the walk, which would find nothing (P_b = 0).
/// Reads the fluid's gather copies (xm, vp): after sph_density or sph_density_predict at the same
/// positions. `walls` (SphLists::walls, or empty): each boundary particle's fluid candidates,
/// read instead of the walk where its row is complete. `rows` (null: every boundary particle):
/// the particles the pass runs over. `dry_written`: a pass over these walls' lists wrote every
/// particle since they were built, so a dry one (an empty row: no fluid within h + s of it at
/// the build, none within h until the next) holds its values (P_b = 0) and is skipped.
template <typename T>
void boundary_pressure(const exec::Exec& ex, const SphParams<T>& prm, BoundaryView<T> b,
                       const FluidView<T>& f, CellView<T> fluid_cells, const RigidShape<T>* shapes,
                       const std::uint8_t* fluid_near = nullptr, const ListView<T>& walls = {},
                       const exec::Rows* rows = nullptr, bool dry_written = false);

/// The continuity equation's part of a step before the neighbour pass (prm.density =
/// Continuity): the pressure of the density predicted for the step's end, rho + dt (2 drho -
/// drho_prev), and the gather copies, for every fluid particle.
template <typename T>
void sph_density_predict(const exec::Exec& ex, const SphParams<T>& prm, FluidView<T> f, T dt);

/// a_i = g + pressure (Eq. 3) + viscosity (Eq. 4) + boundary pressure, for every fluid particle.
/// After sph_density (or sph_density_predict, with the same dt) at the same positions: it reads
/// the gather copies that pass wrote. Under the continuity equation the same pass also gives
/// drho_i/dt and takes the density's step, rho += dt drho (dt 0: the rate at t = 0 only).
/// `rows` (null: every fluid particle): the particles the pass runs over.
template <typename T>
void sph_forces(const exec::Exec& ex, const SphParams<T>& prm, FluidView<T> f, CellView<T> cells,
                const BoundaryNeighbours<T>& b, const ListView<T>& list = {}, T dt = T(0),
                const exec::Rows* rows = nullptr);

/// Adds to *work (memory on ex.backend; nothing waits) the work the moving solids' boundary
/// particles did on the fluid over the step dt, from the forces pass's pair forces
/// (MoverWorkEvaluator): call after sph_forces at the same positions. b must carry obstacle and
/// shapes. owned (null: every row): a rank's owned fluid, flagged 1.
template <typename T>
void sph_mover_work(const exec::Exec& ex, const SphParams<T>& prm, const FluidView<T>& f,
                    const BoundaryNeighbours<T>& b, const std::uint32_t* owned, T dt, double* work);

} // namespace kf
