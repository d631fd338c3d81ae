// The domain's blocks shared out among ranks (domain/Decomposition): every block has one owner,
// the ghosts a rank would receive are exactly the points within the ghost width of its region
// (against a brute-force distance to every block), METIS's parts balance the cost of a skewed
// scene, and the partition is the same every time it is computed (every rank computes it).
#include "core/Error.hpp"
#include "domain/Decomposition.hpp"

#include "support/RandomPoints.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <set>
#include <vector>

using namespace kf;

namespace {

using Counts = std::vector<std::array<double, kPhases>>;

Counts count_points(const BlockGrid& g, const std::vector<Vec3d>& x, Phase p) {
  Counts c(g.count(), {0, 0, 0});
  for (const Vec3d& q : x)
    c[g.block_of(q)][static_cast<int>(p)] += 1;
  return c;
}

using test::uniform_points;

// Fluid piled into one half of the box [0, 0.8] x [0, 0.4] x [0, 0.6] and some spread over all
// of it, so the parts are uneven in shape.
std::vector<Vec3d> piled_points(const Vec3d& lo, const Vec3d& hi) {
  auto x = uniform_points(6000, lo, {0.4, 0.4, 0.3}, 3);
  const auto spread = uniform_points(2000, lo, hi, 4);
  x.insert(x.end(), spread.begin(), spread.end());
  return x;
}

} // namespace

TEST(BlockGrid, PointsFallInTheBlockWhoseBoxHoldsThemAndOutsidePointsInAnEdgeBlock) {
  const BlockGrid g({0, 0, 0}, {1.0, 0.5, 0.3}, 0.1);
  EXPECT_EQ(g.nx(), 10);
  EXPECT_EQ(g.ny(), 5);
  EXPECT_EQ(g.nz(), 3);
  for (const Vec3d& x : uniform_points(2000, {0, 0, 0}, {1.0, 0.5, 0.3}, 1)) {
    const int b = g.block_of(x);
    EXPECT_EQ(g.distance(x, b), 0.0);
  }
  EXPECT_EQ(g.block_of({-5, 0.25, 0.15}), g.block_of({0.01, 0.25, 0.15}));
  EXPECT_EQ(g.block_of({7, 9, 11}), g.count() - 1);
  // Edge blocks are open outward: a point past the box is at distance 0 from its own block.
  EXPECT_EQ(g.distance({7, 9, 11}, g.count() - 1), 0.0);
  EXPECT_NEAR(g.distance({0.05, 0.05, 0.05}, g.index(2, 0, 0)), 0.15, 1e-15);
}

TEST(Decomposition, OneRankOwnsEverythingAndNeedsNoGhosts) {
  const BlockGrid g({0, 0, 0}, {1, 1, 1}, 0.25);
  const auto x = uniform_points(500, {0, 0, 0}, {1, 1, 1}, 2);
  const Decomposition d =
      Decomposition::partition(g, count_points(g, x, Phase::Fluid), PhaseCosts{}, 1, 0.05);
  std::vector<int> ghosts;
  for (const Vec3d& q : x) {
    EXPECT_EQ(d.owner(q), 0);
    d.ghost_ranks(q, 0.05, ghosts);
    EXPECT_TRUE(ghosts.empty());
  }
}

// For 2, 3, 4 and 7 ranks and ghost widths below, at and above one block edge: the ranks the
// query names for each point are exactly those (other than its owner) whose region lies within
// the width, by the distance to each of their blocks.
TEST(Decomposition, GhostRanksAreExactlyTheRanksWithinTheWidthByBruteForce) {
  const Vec3d lo{0, 0, 0}, hi{0.8, 0.4, 0.6};
  const BlockGrid g(lo, hi, 0.05);
  const auto x = piled_points(lo, hi);
  const auto counts = count_points(g, x, Phase::Fluid);
  std::size_t checked = 0, ghosts_total = 0;
  for (int ranks : {2, 3, 4, 7}) {
    const Decomposition d = Decomposition::partition(g, counts, PhaseCosts{}, ranks, 0.02);
    std::set<int> used(d.owners().begin(), d.owners().end());
    EXPECT_EQ(static_cast<int>(used.size()), ranks) << "a rank got no block";
    for (double width : {0.013, 0.05, 0.071}) {
      std::vector<int> got;
      for (const Vec3d& q : x) {
        d.ghost_ranks(q, width, got);
        std::vector<int> want;
        for (int r = 0; r < ranks; ++r)
          if (r != d.owner(q) && d.distance_to_region(q, r) < width)
            want.push_back(r);
        ASSERT_EQ(got, want) << ranks << " ranks, width " << width << ", point (" << q.x << ", "
                             << q.y << ", " << q.z << ")";
        ghosts_total += got.size();
        ++checked;
      }
    }
  }
  std::printf("%zu point queries, %zu ghost copies, all as brute force\n", checked, ghosts_total);
  EXPECT_GT(ghosts_total, checked / 20) << "too few ghosts for the check to mean much";
}

// A rank's grids are a window of the whole grid (Decomposition::window): it must hold the cell
// of every point within `margin` of the rank's blocks (brute force over points near and past the
// blocks, the domain's outside included: those clamp into the edge cells) and be no larger than
// the blocks' box widened by the margin and a cell each side (open where a block is at the edge).
TEST(Decomposition, AWindowHoldsEveryPointWithinTheMarginOfTheRanksBlocks) {
  const Vec3d lo{0, 0, 0}, hi{0.8, 0.4, 0.6};
  const BlockGrid g(lo, hi, 0.05);
  const auto x = piled_points(lo, hi);
  const auto counts = count_points(g, x, Phase::Fluid);
  // The run's grid: cells of 0.0137 m from one cell below the domain (NeighbourGrid::cover).
  const double cell = 0.0137;
  const Vec3d origin{-cell, -cell, -cell};
  const std::array<int, 3> n{int(std::ceil(0.8 / cell)) + 2, int(std::ceil(0.4 / cell)) + 2,
                             int(std::ceil(0.6 / cell)) + 2};
  const auto cell_of = [&](const Vec3d& q, int a) {
    const double o[3] = {origin.x, origin.y, origin.z}, v[3] = {q.x, q.y, q.z};
    return std::clamp(int(std::floor((v[a] - o[a]) / cell)), 0, n[a] - 1);
  };
  const auto probes = uniform_points(20000, {-0.1, -0.1, -0.1}, {0.9, 0.5, 0.7}, 9);
  std::size_t near = 0;
  for (int ranks : {2, 3, 5}) {
    const Decomposition d = Decomposition::partition(g, counts, PhaseCosts{}, ranks, 0.02);
    for (double margin : {0.011, 0.034}) {
      double total = 0;
      for (int r = 0; r < ranks; ++r) {
        const auto [wlo, whi] = d.window(r, origin, cell, n, margin);
        for (const Vec3d& q : probes) {
          if (d.distance_to_region(q, r) > margin)
            continue;
          ++near;
          for (int a = 0; a < 3; ++a)
            ASSERT_TRUE(cell_of(q, a) >= wlo[a] && cell_of(q, a) <= whi[a])
                << ranks << " ranks, rank " << r << ", margin " << margin << ", axis " << a;
        }
        // No larger than the blocks' box, the margin and a cell (two for the rounding).
        std::array<int, 3> blo{g.nx(), g.ny(), g.nz()}, bhi{-1, -1, -1};
        for (int b = 0; b < g.count(); ++b)
          if (d.owner_of_block(b) == r)
            for (int a = 0; a < 3; ++a) {
              blo[a] = std::min(blo[a], g.coords(b)[a]);
              bhi[a] = std::max(bhi[a], g.coords(b)[a]);
            }
        const double o[3] = {origin.x, origin.y, origin.z};
        const double go[3] = {g.origin().x, g.origin().y, g.origin().z};
        for (int a = 0; a < 3; ++a) {
          const double b0 = go[a] + blo[a] * g.edge() - margin,
                       b1 = go[a] + (bhi[a] + 1) * g.edge() + margin;
          if (blo[a] > 0)
            EXPECT_GE(wlo[a], int(std::floor((b0 - o[a]) / cell)) - 2);
          else
            EXPECT_EQ(wlo[a], 0);
          if (bhi[a] < g.dim(a) - 1)
            EXPECT_LE(whi[a], int(std::floor((b1 - o[a]) / cell)) + 2);
          else
            EXPECT_EQ(whi[a], n[a] - 1);
        }
        total += double(whi[0] - wlo[0] + 1) * (whi[1] - wlo[1] + 1) * (whi[2] - wlo[2] + 1);
      }
      // Some rank's window is smaller than the grid (else the check above is the trivial one).
      EXPECT_LT(total, double(ranks) * n[0] * n[1] * n[2]) << ranks << " ranks";
    }
  }
  EXPECT_GT(near, 20000u);
}

// All the fluid in one corner of a large box (a skewed scene): cost-weighted parts put the
// corner's blocks on every rank, so the ranks' costs are balanced well under the default
// re-partition threshold of 1.1; equal-volume slabs would leave it all on one rank.
TEST(Decomposition, ASkewedSceneIsBalancedByCost) {
  const Vec3d lo{0, 0, 0}, hi{1, 1, 1};
  const BlockGrid g(lo, hi, 0.04);
  const auto x = uniform_points(40000, lo, {0.25, 0.25, 0.25}, 5);
  const auto counts = count_points(g, x, Phase::Fluid);
  for (int ranks : {2, 4, 8}) {
    const Decomposition d = Decomposition::partition(g, counts, PhaseCosts{}, ranks, 0.01);
    const double imb = Decomposition::imbalance(d.rank_costs(counts, PhaseCosts{}));
    // Slabs along x, for comparison: every point lies in the first quarter of the box.
    std::vector<double> slabs(ranks, 0.0);
    for (const Vec3d& q : x)
      slabs[std::min(ranks - 1, static_cast<int>(q.x * ranks))] += 1;
    std::printf("%d ranks: imbalance %.4f (x slabs: %.3f)\n", ranks, imb,
                Decomposition::imbalance(slabs));
    // METIS's allowance with one constraint is 1% (measured 1.0075-1.0100); the blocks are
    // ~1/1000 of the load each.
    EXPECT_LT(imb, 1.012) << ranks << " ranks";
    EXPECT_DOUBLE_EQ(d.tolerance(), Decomposition::kOneConstraintTolerance);
    EXPECT_DOUBLE_EQ(d.landed(), d.worst_phase_imbalance(counts, PhaseCosts{}));
  }
}

// The fluid's stages and the knit's substeps meet at halo refreshes of their own, so each phase
// is balanced on its own (METIS's two constraints): with the fluid in one half of the box and
// the knit in the other, every rank takes a share of both. One constraint on the summed cost
// would balance the sum with one rank all fluid and the other all knit, each idle through the
// other's stages.
TEST(Decomposition, EachPhaseIsBalancedOnItsOwn) {
  const Vec3d lo{0, 0, 0}, hi{1, 0.5, 0.5};
  const BlockGrid g(lo, hi, 0.05);
  const auto fluid = uniform_points(20000, lo, {0.5, 0.5, 0.5}, 6);
  const auto knit = uniform_points(5000, {0.5, 0, 0}, hi, 7);
  Counts counts = count_points(g, fluid, Phase::Fluid);
  const Counts k = count_points(g, knit, Phase::Knit);
  for (int b = 0; b < g.count(); ++b)
    counts[b][static_cast<int>(Phase::Knit)] = k[b][static_cast<int>(Phase::Knit)];
  PhaseCosts costs;
  costs.per_particle = {1.0, 0.1, 0.5};
  costs.knit_substeps = 8; // a knit point costs 4 fluid particles: the knit half weighs 20000
  EXPECT_EQ(costs.of(Phase::Knit), 4.0);
  // Each phase's cost alone (the others' weighed 0).
  const auto only = [&](Phase p) {
    PhaseCosts c = costs;
    for (int q = 0; q < kPhases; ++q)
      if (q != static_cast<int>(p))
        c.per_particle[q] = 0;
    return c;
  };
  for (int ranks : {2, 4}) {
    const Decomposition d = Decomposition::partition(g, counts, costs, ranks, 0.02);
    const double all = Decomposition::imbalance(d.rank_costs(counts, costs));
    const double f = Decomposition::imbalance(d.rank_costs(counts, only(Phase::Fluid)));
    const double kn = Decomposition::imbalance(d.rank_costs(counts, only(Phase::Knit)));
    std::printf("%d ranks: imbalance %.4f, fluid alone %.4f, knit alone %.4f\n", ranks, all, f, kn);
    // METIS's tolerance is 3% on each constraint (two: the allowance stays 3%, measured
    // 1.027-1.030); a block holds ~1/400 of a phase.
    EXPECT_DOUBLE_EQ(d.tolerance(), Decomposition::kTolerance);
    EXPECT_LT(all, 1.05) << ranks << " ranks";
    EXPECT_LT(f, 1.05) << ranks << " ranks: the fluid's stages";
    EXPECT_LT(kn, 1.05) << ranks << " ranks: the knit's substeps";
    EXPECT_NEAR(d.worst_phase_imbalance(counts, costs), std::max(f, kn), 1e-12);
    EXPECT_FALSE(Decomposition::repartition_promises(d.worst_phase_imbalance(counts, costs)));
  }
  // A partition that balanced the summed cost alone (the knit's weight counted as fluid: METIS
  // cuts the box across its length, the fluid's half from the knit's): balanced by the sum, but
  // each rank idle through the other's stages. The re-partition's rule reads the phases.
  Counts lumped(g.count(), {0, 0, 0});
  for (int b = 0; b < g.count(); ++b)
    lumped[b][static_cast<int>(Phase::Fluid)] =
        counts[b][static_cast<int>(Phase::Fluid)] + 4.0 * counts[b][static_cast<int>(Phase::Knit)];
  const Decomposition by_sum = Decomposition::partition(g, lumped, PhaseCosts{}, 2, 0.02);
  const double sum = Decomposition::imbalance(by_sum.rank_costs(counts, costs));
  const double phases = by_sum.worst_phase_imbalance(counts, costs);
  std::printf("balanced by the sum: %.4f summed, %.3f by its worst phase\n", sum, phases);
  EXPECT_LT(sum, 1.05);
  EXPECT_GT(phases, 1.8) << "the cut across the box's length: each phase on one rank";
  EXPECT_TRUE(Decomposition::repartition_promises(phases));
}

// A dam break's tank: the walls far from the fluid cost the walls' pass next to nothing (it skips
// cells without fluid around), so only the walls beside fluid weigh. Weighed all alike, the
// empty tank's walls (here 3x the column's fluid at 0.1 each: 30% of the cost) take fluid off
// the rank that holds them: the fluid's stages, most of the step, then run unevenly (the 8M dam
// break on 2 ranks: 4.01M / 3.90M fluid, 2.7% apart).
TEST(Decomposition, OnlyTheWallsBesideFluidWeigh) {
  const Vec3d lo{0, 0, 0}, hi{1.0, 0.2, 0.6};
  const BlockGrid g(lo, hi, 0.04);
  const auto fluid = uniform_points(20000, lo, {0.2, 0.2, 0.4}, 8);
  // Walls: a shell of points over the floor and the two long sides of the whole tank.
  std::vector<Vec3d> walls = uniform_points(40000, lo, {1.0, 0.2, 0.01}, 9);
  for (const Vec3d& q : uniform_points(20000, lo, {1.0, 0.01, 0.6}, 10))
    walls.push_back(q);
  Counts counts = count_points(g, fluid, Phase::Fluid);
  const Counts w = count_points(g, walls, Phase::Boundary);
  for (int b = 0; b < g.count(); ++b)
    counts[b][static_cast<int>(Phase::Boundary)] = w[b][static_cast<int>(Phase::Boundary)];
  const Counts working = Decomposition::working_counts(g, counts);
  // Brute force: a wall point weighs where fluid lies within one block of its block's box.
  std::set<std::array<int, 3>> fluid_blocks;
  for (const Vec3d& f : fluid)
    fluid_blocks.insert(g.coords_of(f));
  std::vector<char> near(walls.size(), 0);
  for (std::size_t i = 0; i < walls.size(); ++i) {
    const auto c = g.coords_of(walls[i]);
    for (const auto& d : fluid_blocks)
      near[i] = near[i] || (std::abs(c[0] - d[0]) <= 1 && std::abs(c[1] - d[1]) <= 1 &&
                            std::abs(c[2] - d[2]) <= 1);
  }
  double counted = 0;
  for (const auto& c : working)
    counted += c[static_cast<int>(Phase::Boundary)];
  const double near_count = std::count(near.begin(), near.end(), 1);
  EXPECT_EQ(counted, near_count);
  EXPECT_LT(near_count, 0.35 * walls.size()) << "most walls are far from the column";
  for (int ranks : {2, 4}) {
    const Decomposition d = Decomposition::partition(g, counts, PhaseCosts{}, ranks, 0.02);
    // Each rank's cost, by hand: its fluid, and 0.1 for each of its walls' points beside fluid.
    std::vector<double> want(ranks, 0.0);
    for (const Vec3d& f : fluid)
      want[d.owner(f)] += 1.0;
    for (std::size_t i = 0; i < walls.size(); ++i)
      want[d.owner(walls[i])] += near[i] ? 0.1 : 0.0;
    const auto got = d.rank_costs(counts, PhaseCosts{});
    for (int r = 0; r < ranks; ++r)
      EXPECT_NEAR(got[r], want[r], 1e-9 * want[r]) << ranks << " ranks, rank " << r;
    const double all = Decomposition::imbalance(got);
    std::printf("%d ranks: the working cost's imbalance %.4f\n", ranks, all);
    // METIS's 1% allowance (one constraint) plus a block's share (~1/150 of the column);
    // measured 1.0083-1.0087.
    EXPECT_LT(all, 1.017) << ranks << " ranks";
  }
  // Without fluid every boundary particle counts (a rigid body's own scene).
  const Counts only_walls = count_points(g, walls, Phase::Boundary);
  EXPECT_EQ(Decomposition::working_counts(g, only_walls), only_walls);
}

TEST(Decomposition, TheSamePartitionEveryTime) {
  const BlockGrid g({0, 0, 0}, {1, 1, 1}, 0.1);
  const auto x = uniform_points(10000, {0, 0, 0}, {0.6, 1, 0.4}, 8);
  const auto counts = count_points(g, x, Phase::Fluid);
  const auto a = Decomposition::partition(g, counts, PhaseCosts{}, 5, 0.02);
  const auto b = Decomposition::partition(g, counts, PhaseCosts{}, 5, 0.02);
  EXPECT_EQ(a.owners(), b.owners());
}

TEST(Decomposition, BadRequestsAreClearErrors) {
  const BlockGrid g({0, 0, 0}, {1, 1, 1}, 0.5); // 8 blocks
  const Counts counts(g.count(), {1, 0, 0});
  EXPECT_THROW(Decomposition::partition(g, counts, PhaseCosts{}, 9, 0.1), Error);
  EXPECT_THROW(Decomposition::partition(g, counts, PhaseCosts{}, 0, 0.1), Error);
  EXPECT_THROW(Decomposition::partition(g, Counts(3), PhaseCosts{}, 2, 0.1), Error);
  EXPECT_THROW(BlockGrid({0, 0, 0}, {1, 1, 1}, 0.0), Error);
}

namespace {

/// A job's imbalance over `intervals` checks: `excess(k)` is the slowest rank's compute over the
/// mean in the k-th interval after a re-partition (k = 1, 2, ...), what a re-partition resets;
/// a re-partition costs `cost`. Returns the time lost (excess paid plus re-partitions) when
/// `decide(excess, held, last_cost)` chooses at each check.
template <typename Excess, typename Decide>
double time_lost(int intervals, double cost, Excess excess, Decide decide) {
  double lost = 0, last_cost = 0;
  std::uint64_t held = 0;
  for (int i = 0; i < intervals; ++i) {
    ++held;
    const double e = excess(held);
    lost += e;
    if (decide(e, held, last_cost)) {
      lost += cost;
      last_cost = cost;
      held = 0;
    }
  }
  return lost;
}

/// The least time lost by re-partitioning every p intervals, p = 1 .. intervals (brute force).
template <typename Excess>
double best_period(int intervals, double cost, Excess excess) {
  double best = std::numeric_limits<double>::infinity();
  for (int p = 1; p <= intervals; ++p)
    best = std::min(best,
                    time_lost(intervals, cost, excess,
                              [p](double, std::uint64_t held, double) { return int(held) >= p; }));
  return best;
}

} // namespace

// [parallel] payback: a re-partition must save, over as many intervals as the last one held,
// what the last one cost. Against a brute-force search of the best fixed period, on two models
// of a job: an imbalance a re-partition cannot remove (ranks sharing a GPU: each interval loses
// the same), and one that grows after each re-partition (the fluid drifting to one rank). The
// rule loses at most about twice the best period's time (it re-partitions once the imbalance has
// lost what a re-partition costs: the rent-or-buy bound), where re-partitioning at every check
// loses up to many times more.
TEST(Decomposition, ARepartitionMustPayForItself) {
  const auto rule = [](double e, std::uint64_t held, double last_cost) {
    return Decomposition::repartition_pays(e, 0.0, held, last_cost);
  };
  const auto always = [](double, std::uint64_t, double) { return true; };
  const int n = 400;
  const double cost = 0.7; // seconds (the 8M dam break on 2 ranks sharing one H200)
  // The first re-partition always goes ahead (nothing measured yet).
  EXPECT_TRUE(Decomposition::repartition_pays(1.0, 1.0, 1, 0.0));
  EXPECT_FALSE(Decomposition::repartition_pays(1.06, 1.0, 3, 0.7)); // 0.18 s saved < 0.7
  EXPECT_TRUE(Decomposition::repartition_pays(1.06, 1.0, 12, 0.7)); // 0.72 s >= 0.7
  for (double e : {0.01, 0.06, 0.3}) {
    const auto constant = [e](std::uint64_t) { return e; };
    const double best = best_period(n, cost, constant);
    const double ruled = time_lost(n, cost, constant, rule);
    EXPECT_LE(ruled, 2.0 * best + cost) << "constant excess " << e;
    // At every check: (e + cost) an interval; the rule's ~(e + cost / ceil(cost / e)): 1.9x at
    // e = 0.3 (every third interval), 7-35x below.
    EXPECT_GT(time_lost(n, cost, constant, always), (e < 0.1 ? 5.0 : 1.5) * ruled)
        << "constant excess " << e;
  }
  for (double d : {0.001, 0.01, 0.1}) {
    const auto drift = [d](std::uint64_t k) { return d * double(k); };
    const double best = best_period(n, cost, drift);
    const double ruled = time_lost(n, cost, drift, rule);
    // Measured 1.02-1.11x the best period here (a growing imbalance: the rule's moment is near
    // the best one); 1.75-1.94x on the constant excess above (the bound: 2x).
    EXPECT_LE(ruled, 1.2 * best) << "drift " << d;
  }
}

// [parallel] payback: a re-partition goes ahead only where the counts are off balance by more
// than twice METIS's allowance (a measured imbalance past the trigger that the particles do not
// show is the ranks' sharing of a GPU, which no partition removes). The rule stands on METIS
// landing within it: a partition fresh from METIS never promises another, whatever the field
// and the rank count; once the fluid has moved (a column fallen onto the floor) it does, and the
// partition made then does not.
TEST(Decomposition, ARepartitionPromisesOnlyWhereTheCountsAreOffBalance) {
  EXPECT_FALSE(Decomposition::repartition_promises(1.0));
  EXPECT_FALSE(Decomposition::repartition_promises(1.059)); // 2 x 3%: 1.06
  EXPECT_TRUE(Decomposition::repartition_promises(1.061));
  EXPECT_TRUE(Decomposition::repartition_promises(1.011, 1.005)); // an allowance of 0.5%
  EXPECT_FALSE(Decomposition::repartition_promises(1.019, 1.01)); // one constraint's 1%
  EXPECT_TRUE(Decomposition::repartition_promises(1.021, 1.01));
  // A partition that landed past its allowance (coarse blocks) promises only past that landing.
  EXPECT_FALSE(Decomposition::repartition_promises(1.034, 1.01, 1.025));
  EXPECT_TRUE(Decomposition::repartition_promises(1.036, 1.01, 1.025));
  const Vec3d lo{0, 0, 0}, hi{1, 1, 1};
  const BlockGrid g(lo, hi, 0.04);
  const auto column = count_points(g, uniform_points(40000, lo, {0.3, 0.9, 0.3}, 21), Phase::Fluid);
  const auto fallen = count_points(g, uniform_points(40000, lo, {1, 0.15, 1}, 22), Phase::Fluid);
  for (int ranks : {2, 3, 4, 8}) {
    const Decomposition before = Decomposition::partition(g, column, PhaseCosts{}, ranks, 0.01);
    const double fresh = Decomposition::imbalance(before.rank_costs(column, PhaseCosts{}));
    const double moved = Decomposition::imbalance(before.rank_costs(fallen, PhaseCosts{}));
    const Decomposition after = Decomposition::partition(g, fallen, PhaseCosts{}, ranks, 0.01);
    const double again = Decomposition::imbalance(after.rank_costs(fallen, PhaseCosts{}));
    std::printf("%d ranks: counted %.4f fresh, %.3f once fallen, %.4f re-partitioned\n", ranks,
                fresh, moved, again);
    // METIS lands within twice its allowance (1% here: one constraint)...
    EXPECT_FALSE(Decomposition::repartition_promises(fresh, before.tolerance())) << ranks;
    EXPECT_FALSE(Decomposition::repartition_promises(again, after.tolerance())) << ranks;
    // ... and RankExchange asks with each partition's own allowance and landing.
    EXPECT_DOUBLE_EQ(before.landed(), fresh) << ranks << " ranks";
    EXPECT_FALSE(Decomposition::repartition_promises(fresh, before.tolerance(), before.landed()))
        << ranks << " ranks";
    EXPECT_TRUE(Decomposition::repartition_promises(moved, before.tolerance(), before.landed()))
        << ranks << " ranks";
    EXPECT_FALSE(Decomposition::repartition_promises(again, after.tolerance(), after.landed()))
        << ranks << " ranks";
  }
}

// Past kMostGraphVertices blocks METIS is given groups of m x m x m blocks (its time grows with
// the graph; every rank pays it at each re-partition): each group's blocks share one rank, and
// the balance stays near the block graph's.
TEST(Decomposition, ALargeGraphIsPartitionedByGroupsOfBlocks) {
  const BlockGrid g({0, 0, 0}, {0.9, 0.9, 0.9}, 0.03); // 30^3 = 27,000 blocks: groups of 2^3
  ASSERT_GT(g.count(), Decomposition::kMostGraphVertices);
  const BlockGrid groups = g.coarsened(2);
  EXPECT_EQ(groups.nx(), 15);
  EXPECT_EQ(groups.count(), 15 * 15 * 15);
  EXPECT_DOUBLE_EQ(groups.edge(), 0.06);
  EXPECT_EQ(g.coarsened(7).nx(), 5); // 30 = 4 x 7 + 2: the last group cut short
  EXPECT_THROW(g.coarsened(0), Error);
  // A column of fluid in one corner over a thin layer everywhere, and walls along the sides.
  auto x = uniform_points(60000, {0, 0, 0}, {0.35, 0.9, 0.55}, 11);
  const auto layer = uniform_points(20000, {0, 0, 0}, {0.9, 0.9, 0.1}, 12);
  x.insert(x.end(), layer.begin(), layer.end());
  std::vector<Vec3d> walls;
  for (double a = 0.005; a < 0.9; a += 0.01)
    for (double b = 0.005; b < 0.9; b += 0.01) {
      walls.push_back({0.001, a, b});
      walls.push_back({a, b, 0.001});
    }
  Counts counts = count_points(g, x, Phase::Fluid);
  const Counts w = count_points(g, walls, Phase::Boundary);
  for (int b = 0; b < g.count(); ++b)
    counts[b][1] = w[b][1];
  for (int ranks : {2, 4, 8}) {
    const Decomposition d = Decomposition::partition(g, counts, PhaseCosts{}, ranks, 0.02);
    for (int b = 0; b < g.count(); ++b) {
      const auto c = g.coords(b);
      EXPECT_EQ(d.owner_of_block(b),
                d.owner_of_block(g.index(c[0] / 2 * 2, c[1] / 2 * 2, c[2] / 2 * 2)))
          << "block " << b << ", " << ranks << " ranks";
    }
    const double grouped = Decomposition::imbalance(d.rank_costs(counts, PhaseCosts{}));
    const double fine = Decomposition::imbalance(
        Decomposition::partition_blocks(g, counts, PhaseCosts{}, ranks, 0.02)
            .rank_costs(counts, PhaseCosts{}));
    // METIS's allowance (1%: one constraint) holds for the groups as for the blocks (measured:
    // groups 1.0067-1.0099, blocks 1.0098-1.0099 on 2, 4, 8 ranks); a group is 1/3,375 of the
    // domain.
    std::printf("%d ranks: grouped %.4f, blocks %.4f\n", ranks, grouped, fine);
    EXPECT_LT(grouped, 1.012) << ranks << " ranks";
    EXPECT_LT(grouped, fine + 0.003) << ranks << " ranks";
  }
}
