#pragma once
// How a scene is split over ranks before its first step: each phase's ghost width, the blocks,
// the first partition by the particles' counts, and a rank's window of the fluid's and the
// boundary's grid. One set of rules for the run (RankExchange, SimulationT) and for
// `knitflow plan --ranks N` (PartitionPlan), so that the plan prints the run's split.
#include "domain/Decomposition.hpp"
#include "domain/Scene.hpp"
#include "kernels/grid/GridGeometry.hpp"

#include <algorithm>
#include <array>
#include <functional>
#include <span>
#include <vector>

namespace kf::comm {
class MpiContext;
}

namespace kf {

/// What the set-up knows of the knit and the coupling when it splits the job (SimulationT).
struct SplitInputs {
  double knit_width = 0;     // the knit's reach (KnitHalo::base_width; 0: no knit)
  double knit_skin = 0;      // how far a knit point strays before its ghosts are chosen anew
                             // (0: half knit_width)
  double coupling_reach = 0; // the knit-fluid coupling's, with the knit's stray (0: none)
  double skin = 0;           // the fluid's "verlet" lists' skin, absolute (0: none)
};

/// Each phase's ghost width (DESIGN §6): the farthest another rank's particle of that phase can
/// act on one of this rank's before the ghosts are chosen again.
struct HaloWidths {
  double fluid = 0;    // the support or the coupling's reach, plus the skin
  double boundary = 0; // the support plus the skin (0: no boundary)
  double walls = 0;    // the fluid's beside walls: a ghost wall finds all its fluid (0: no walls)
  double knit = 0;     // the knit's first choice (KnitHalo widens it where a spring stretched)
  double skin = 0;     // the fluid's lists' skin
  double block = 0;    // a block's edge
  double halo_weight = 0; // the width the block graph's edges weigh the halo by
  /// The farthest a particle a rank sorts into its fluid or boundary grid lies outside its
  /// blocks.
  double widest() const { return std::max({fluid, boundary, walls}); }
  /// A rank's grid window's margin past its blocks: the widest width and the motion since the
  /// sort (the skin).
  double grid_margin() const { return widest() + skin; }
};

HaloWidths halo_widths(const Scene& scene, const SplitInputs& in);

/// The knit's skin as KnitHalo takes it: the given one, or half its base width.
inline double knit_ghost_skin(double knit_width, double knit_skin) {
  return knit_skin > 0 ? knit_skin : 0.5 * knit_width;
}

/// The phases' costs a particle until the run has measured them.
PhaseCosts initial_costs(const Scene& scene);

/// A phase's points, handed to a sink one by one each time it is called: a sampler run again
/// instead of a scene kept whole (a rank of a split job keeps only its share).
template <typename T>
using PointSource = std::function<void(const std::function<void(const Vec3<T>&)>&)>;

/// Where each rank holds a share of the points (a restart's frame read in shares): how the box
/// and the counts a block are combined over the ranks before the partition (unset: every rank
/// holds all the points).
struct PointShares {
  std::function<void(Vec3d& lo, Vec3d& hi)> box;
  std::function<void(std::vector<std::array<double, kPhases>>& counts)> counts;
};

/// Shares combined over the job's ranks: the box by min and max, the counts summed.
PointShares point_shares(const comm::MpiContext& mpi);

/// The first partition: blocks of `w.block` over the domain widened to every particle (walls'
/// particles and knit may lie outside it), weighted by each phase's count and `costs`. Each
/// source is run twice (the box, then the counts a block).
template <typename T>
Decomposition first_partition(const Scene& scene, const HaloWidths& w, const PhaseCosts& costs,
                              int ranks, const std::array<PointSource<T>, kPhases>& points,
                              const PointShares& shares = {});
/// The same over points held whole.
template <typename T>
Decomposition first_partition(const Scene& scene, const HaloWidths& w, const PhaseCosts& costs,
                              int ranks, std::span<const Vec3<T>> fluid,
                              std::span<const Vec3<T>> boundary, std::span<const Vec3<T>> knit);

/// The rank that owns a point by `d`, the point where the run holds it (in T). Out of line on
/// purpose: inlined into the start's sampling loop, GCC 12 at -O2 and -O3 (its SLP vectorizer;
/// -O1 and -fno-tree-slp-vectorize did not) took a sample's x and y from the double it was
/// rounded from, not from the float, so a rank kept samples the owners' rule gives to another
/// (test_distributed_mpi's ThePlanIsTheRunsSplit on 4 ranks: 7,308 walls against 7,300). A
/// point passed by reference to another unit is the float in memory.
template <typename T>
int owner_of(const Decomposition& d, const Vec3<T>& q);
/// Whether rank r owns a point by `d` (owner_of).
template <typename T>
bool owns(const Decomposition& d, int r, const Vec3<T>& q);

/// The indices of the points of `x` rank r owns by `d`, ascending (a rank keeps its share of a
/// whole scene or frame in its order).
template <typename T>
std::vector<std::size_t> owned_rows(const Decomposition& d, int r, std::span<const Vec3<T>> x);

/// The fluid's and the boundary's grid on one rank: the domain in cells of the support plus the
/// skin over the span (a walk stays exact between the lists' builds: SphLists).
template <typename T>
GridGeometry<T> whole_grid(const Scene& scene);

/// Rank r's window of `whole`: the cells that hold what it sorts (Decomposition::window with
/// w.grid_margin()).
template <typename T>
GridGeometry<T> rank_grid(const Decomposition& d, int r, const GridGeometry<T>& whole,
                          const HaloWidths& w);

} // namespace kf
