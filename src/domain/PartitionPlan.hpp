#pragma once
// What `knitflow plan --ranks N` prints about the split: the scene's particles placed as a run
// starts them, the blocks partitioned as the run partitions them (domain/RankLayout), and per
// rank the particles it owns and the ghosts it receives for each phase, with the bytes a step
// would exchange. Host-only.
#include "domain/Decomposition.hpp"
#include "domain/RankLayout.hpp"
#include "domain/Scene.hpp"
#include "kernels/grid/GridGeometry.hpp"

#include <array>
#include <cstddef>
#include <span>
#include <vector>

namespace kf {

/// Bytes a ghost of each phase costs a step: the fields refreshed in place between rebuilds
/// (fluid x, v before the density pass and rho, P before the forces; knit x, v every substep and
/// saturation; boundary x when solids move: the ghost walls' pressures are computed where they
/// are).
std::array<std::size_t, kPhases> ghost_bytes_per_step(const Scene& scene);

struct RankShare {
  std::array<std::size_t, kPhases> owned{0, 0, 0}, ghosts{0, 0, 0};
  double cost = 0;
  std::size_t bytes_per_step = 0; // received
  int neighbours = 0;             // ranks it receives ghosts from
  std::size_t grid_cells = 0;     // its fluid and boundary grids' window (Decomposition::window)
};

struct PartitionReport {
  int ranks = 1;
  int blocks[3] = {1, 1, 1};
  double block_edge = 0;
  HaloWidths widths;
  PhaseCosts costs;
  double imbalance = 1;
  std::size_t domain_cells = 0; // the grids' on one rank (0: no fluid or boundary)
  std::vector<RankShare> rank;
};

/// What each rank of `d` owns and receives of the particles `x[phase]` (in the run's precision:
/// a point's block and cell as the run finds them), by the widths `w` (the ghosts as
/// RankExchange chooses them at the start; the knit's as KnitHalo first chooses them) and each
/// rank's window of `whole` (the fluid's and the boundary's grid on one rank; nullptr where the
/// scene has neither).
template <typename T>
PartitionReport describe_partition(const Scene& scene, const Decomposition& d, const HaloWidths& w,
                                   const PhaseCosts& costs,
                                   const std::array<std::span<const Vec3<T>>, kPhases>& x,
                                   const GridGeometry<T>* whole);

} // namespace kf
