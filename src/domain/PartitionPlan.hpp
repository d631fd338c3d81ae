#pragma once
// What `knitflow plan --ranks N` prints about the split: the scene's particles placed as they
// start, the blocks partitioned (domain/Decomposition), and per rank the particles it owns and
// the ghosts it receives for each phase, with the bytes a step would exchange. Host-only.
#include "domain/Decomposition.hpp"
#include "domain/Scene.hpp"
#include "domain/Simulation.hpp"

#include <array>
#include <cstddef>
#include <vector>

namespace kf {

/// Ghost widths per phase: the farthest another rank's particle of that phase can act on one of
/// this rank's (DESIGN §6).
struct GhostWidths {
  std::array<double, kPhases> width{0, 0, 0};
  /// The fluid's beside walls (twice the boundary's: a ghost wall finds all its fluid; 0: no
  /// walls).
  double fluid_beside_walls = 0;
  double of(Phase p) const { return width[static_cast<int>(p)]; }
};

/// The widths a scene needs: fluid and boundary the support radius (plus the "verlet" lists'
/// skin) or the fluid-knit contact reach if larger, the fluid twice the boundary's beside walls;
/// knit the longest spring stretched by half, the self-contact diameter or the contact reach.
/// `longest_spring`, `self_radius` and `coupling_reach` come from the built knit and coupling
/// (0 where absent).
GhostWidths ghost_widths(const Scene& scene, double longest_spring, double self_radius,
                         double coupling_reach);

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
  GhostWidths widths;
  PhaseCosts costs;
  double imbalance = 1;
  std::size_t domain_cells = 0; // the grids' on one rank (0: no fluid or boundary)
  std::vector<RankShare> rank;
};

/// Partitions the scene's initial particles `x[phase]` over `ranks`.
PartitionReport plan_partition(const Scene& scene, const std::array<std::vector<Vec3d>, kPhases>& x,
                               const GhostWidths& widths, int ranks);

/// The same from the scene alone: its particles sampled and its knit built as a run starts them,
/// the widths from `plan` (Simulation::plan's coupling reach and self-contact radius).
PartitionReport plan_partition(const Scene& scene, const PlanReport& plan, int ranks);

} // namespace kf
