#pragma once
// The domain cut into blocks of cells and the blocks shared out among ranks (DESIGN §6). A block
// graph, each block weighted by the cost of the particles in it and joined to its 26 neighbours
// by the halo they would exchange, is partitioned by METIS into one part per rank. A rank owns
// the particles in its blocks; another rank needs a particle as a ghost when it lies within the
// ghost width of one of that rank's blocks. Host-only and deterministic: every rank computes the
// same partition from the same counts. No MPI here: counts are reduced by the caller.
#include "core/Vec3.hpp"
#include "kernels/grid/BlockOwners_K.hpp"

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace kf {

/// The particle phases a block's cost and a halo are counted for.
enum class Phase : int { Fluid = 0, Boundary = 1, Knit = 2 };
inline constexpr int kPhases = 3;
const char* phase_name(Phase p);

/// Cost of one particle of each phase in a step, relative to a fluid particle. The defaults are
/// P4's single-GPU stage times per particle (docs/PERFORMANCE.md: the pour); a run replaces them
/// by what it measures. A knit point's cost is per substep.
struct PhaseCosts {
  std::array<double, kPhases> per_particle{1.0, 0.1, 0.25};
  int knit_substeps = 1;
  double of(Phase p) const {
    const double c = per_particle[static_cast<int>(p)];
    return p == Phase::Knit ? c * knit_substeps : c;
  }
};

/// The blocks: a regular grid of edge `block` over [lo, hi] (the last blocks may reach past hi).
/// A point outside the box belongs to the nearest edge block.
class BlockGrid {
public:
  BlockGrid() = default;
  BlockGrid(const Vec3d& lo, const Vec3d& hi, double block);

  int nx() const { return n_[0]; }
  int ny() const { return n_[1]; }
  int nz() const { return n_[2]; }
  int dim(int d) const { return n_[d]; }
  int count() const { return n_[0] * n_[1] * n_[2]; }
  double edge() const { return edge_; }
  const Vec3d& origin() const { return lo_; }

  int index(int i, int j, int k) const { return i + n_[0] * (j + n_[1] * k); }
  std::array<int, 3> coords(int b) const;
  std::array<int, 3> coords_of(const Vec3d& x) const; // clamped to the grid
  int block_of(const Vec3d& x) const;
  /// Distance from x to block b's box (0 inside). Edge blocks reach to infinity outward, as the
  /// points clamped into them do.
  double distance(const Vec3d& x, int b) const;
  /// How many blocks a ghost width spans on each side.
  int reach(double width) const;
  /// The grid as the owner and ghost evaluators take it (BlockOwners_K.hpp).
  BlockGridView view() const;
  /// The grid of groups of m x m x m blocks (the last ones along each axis may be cut short):
  /// block (i, j, k) lies in group (i / m, j / m, k / m).
  BlockGrid coarsened(int m) const;

private:
  Vec3d lo_{0, 0, 0};
  double edge_ = 1;
  std::array<int, 3> n_{1, 1, 1};
};

/// Which rank owns each block, how the cost falls on the ranks, and which ranks need a point as a
/// ghost.
class Decomposition {
public:
  /// Every block on rank 0 (one rank: no partition).
  explicit Decomposition(BlockGrid grid);

  /// Partitions the block graph into `ranks` parts (METIS_PartGraphKway, contiguous parts) for
  /// the given per-block particle counts per phase, weighted by `costs`. `ghost_width` weights
  /// the graph's edges (the particles two blocks would exchange). `tolerance` is METIS's load
  /// imbalance allowance (1.05: 5%; 0: allowance_for the constraints the counts make). Past
  /// kMostGraphVertices blocks, groups of m x m x m blocks are partitioned instead (the smallest
  /// m that brings them under it), each group's blocks going to its rank.
  static Decomposition partition(const BlockGrid& grid,
                                 const std::vector<std::array<double, kPhases>>& counts,
                                 const PhaseCosts& costs, int ranks, double ghost_width,
                                 double tolerance = 0);
  /// METIS's load imbalance allowance with two constraints (the fluid's stages and the knit's
  /// substeps): 3%. A tighter one costs the coupled scenes halo (the pour on 2 ranks at 1%:
  /// 1.2 -> 2.8 MiB a step, METIS's regions in pieces) for no better balance.
  static constexpr double kTolerance = 1.03;
  /// ... with one: 1%. METIS spends its allowance on the cut (it lands at it: the 8M dam break
  /// 1.029 / 1.030 on 2 / 8 ranks at 3%), and every stage waits for the slowest rank; at 1% it
  /// lands at 1.009 / 1.010 for a halo 5% larger / 4% smaller (`knitflow plan`; docs/
  /// PERFORMANCE.md, "P5: METIS's allowance").
  static constexpr double kOneConstraintTolerance = 1.01;
  /// The allowance for a partition with `constraints` constraints.
  static constexpr double allowance_for(int constraints) {
    return constraints > 1 ? kTolerance : kOneConstraintTolerance;
  }
  /// METIS's time grows with the graph, and every rank pays it at each re-partition: the 8M dam
  /// break's 100,800 blocks took 0.23 s on one core of the 2-core VM, its 13,200 groups of 2 x 2
  /// x 2 0.02 s (balanced within 2.3% against 1.5%; docs/PERFORMANCE.md). 20,000 groups leave
  /// thousands a part up to 8 ranks.
  static constexpr int kMostGraphVertices = 20000;
  /// The same, METIS given the block graph whatever its size (tests compare the two).
  static Decomposition partition_blocks(const BlockGrid& grid,
                                        const std::vector<std::array<double, kPhases>>& counts,
                                        const PhaseCosts& costs, int ranks, double ghost_width,
                                        double tolerance = 0);

  const BlockGrid& grid() const { return grid_; }
  /// The allowance METIS was given (its default for one rank, which needs no call).
  double tolerance() const { return tolerance_; }
  /// Where it landed: the partition's worst_phase_imbalance of the counts it was made from.
  double landed() const { return landed_; }
  int ranks() const { return ranks_; }
  int owner_of_block(int b) const { return owner_[b]; }
  int owner(const Vec3d& x) const { return owner_[grid_.block_of(x)]; }
  const std::vector<int>& owners() const { return owner_; }

  /// The ranks other than x's owner within `width` of x (distance to one of their blocks below
  /// width), ascending, appended to `out` (cleared first).
  void ghost_ranks(const Vec3d& x, double width, std::vector<int>& out) const;
  /// The cells of a grid (its first cell's corner `origin`, edge `cell`, `n` cells an axis)
  /// that hold what rank r sorts: the box of its blocks widened by `margin` (the widest ghost
  /// width and the lists' skin) and one cell for the rounding of a cell's index, open to the
  /// grid's edge where a block is at the block grid's (points past it clamp into it). First and
  /// last cell an axis, inclusive; the whole grid for a rank without blocks.
  std::array<std::array<int, 3>, 2> window(int r, const Vec3d& origin, double cell,
                                           const std::array<int, 3>& n, double margin) const;
  /// The box of rank r's blocks, open (infinite) on a side where one of them is at the block
  /// grid's edge (points past the grid clamp into it): every point r owns lies in it. Empty (lo
  /// above hi) for a rank without blocks.
  std::array<Vec3d, 2> region_box(int r) const;
  /// Distance from x to rank r's region (the union of its blocks); 1e300 for a rank without
  /// blocks. Brute force over every block: for tests and reports.
  double distance_to_region(const Vec3d& x, int r) const;

  /// The counts a block's cost is taken from: where the job holds fluid, a block's boundary
  /// particles count only with fluid in it or a block next to it (the walls' pass skips the
  /// cells without fluid around; the dam break's empty tank, most of its walls, weighed as much
  /// as the walls under the column and took fluid off the rank that held it). Without fluid
  /// every boundary particle counts.
  static std::vector<std::array<double, kPhases>>
  working_counts(const BlockGrid& grid, const std::vector<std::array<double, kPhases>>& counts);
  /// Cost per rank of the given per-block counts (their working_counts).
  std::vector<double> rank_costs(const std::vector<std::array<double, kPhases>>& counts,
                                 const PhaseCosts& costs) const;
  /// The worst of the loads METIS balances, each over its mean: the fluid's stages (fluid and
  /// boundary particles) and, where there is knit, the knit's substeps. The summed cost can
  /// hide a rank with all of one and another with all of the other, each idle through the
  /// other's stages.
  double worst_phase_imbalance(const std::vector<std::array<double, kPhases>>& counts,
                               const PhaseCosts& costs) const;
  /// Slowest rank over the mean (1: perfect balance).
  static double imbalance(const std::vector<double>& per_rank);
  /// Whether a re-partition pays for itself: it saves about what the slowest rank spends over
  /// the mean an interval (`most` - `mean`, seconds of compute since the last check) for about as
  /// many intervals as the last one held (`intervals_held`, this one counted), and must save
  /// `last_cost`, the seconds the last re-partition took (0: none yet, which always pays).
  static bool repartition_pays(double most, double mean, std::uint64_t intervals_held,
                               double last_cost);
  /// Whether a new partition promises a better balance of the counts than the current one's
  /// `counted` imbalance (worst_phase_imbalance, as METIS balances): METIS lands within its
  /// allowance (1.028-1.031 measured for 3%), so a partition counted within twice it has at most
  /// that to gain, and a measured imbalance past the trigger is not the particles' (ranks sharing a
  /// GPU stretch each other's passes: docs/PERFORMANCE.md, P5 on one H200). Where the last
  /// partition `landed` past its allowance (blocks too coarse for it), counted must pass that
  /// landing by the allowance: a new one would land there again.
  static bool repartition_promises(double counted, double tolerance = kTolerance,
                                   double landed = 1.0);

private:
  /// The first and last block coordinates of rank r's blocks along each axis (last -1: none).
  std::array<std::array<int, 3>, 2> block_span(int r) const;

  BlockGrid grid_;
  int ranks_ = 1;
  std::vector<int> owner_;
  double tolerance_ = kOneConstraintTolerance, landed_ = 1.0;
};

} // namespace kf
