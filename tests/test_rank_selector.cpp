// A rebuild's choices made on the particles' backend (domain/RankSelector, the kernels of
// kernels/grid/RankSelection) are the host's: the leavers and their destinations are those of the
// decomposition's owner() and the open sides, the removed mass their sum, and the ghosts sent to
// each neighbour are select_ghosts' lists, which test_decomposition checks against a brute-force
// distance to every block, also with the points of flagged cells going farther (the fluid beside
// walls). On the CPU backend, and on CUDA where a GPU is visible; also with more than 64
// neighbours (the ghost masks' windows).
#include "domain/DeviceRows.hpp"
#include "domain/GhostSelection.hpp"
#include "domain/RankSelector.hpp"

#include "support/RandomPoints.hpp"

#include "support/Backends.hpp"
#include "support/VecCast.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

using namespace kf;

namespace {

using test::backends;

using test::uniform_points;

Decomposition split(const BlockGrid& g, const std::vector<Vec3d>& x, int ranks) {
  std::vector<std::array<double, kPhases>> c(g.count(), {0, 0, 0});
  for (const Vec3d& q : x)
    c[g.block_of(q)][0] += 1;
  return Decomposition::partition(g, c, PhaseCosts{}, ranks, 0.02);
}

template <typename T>
void departures_are_the_hosts(exec::Backend b) {
  // Points spilling past the box on every side; the high x and low z sides are open.
  const Vec3d lo{0, 0, 0}, hi{0.6, 0.3, 0.4};
  const BlockGrid g(lo, hi, 0.05);
  const auto xd = uniform_points(20000, {-0.03, -0.03, -0.03}, {0.63, 0.33, 0.43}, 7);
  const std::array<bool, 6> walls{true, false, true, true, false, true};
  const auto x = test::vec_cast_all<T>(xd);
  std::vector<T> m(x.size());
  for (std::size_t i = 0; i < m.size(); ++i)
    m[i] = T(1) + T(i % 13) / T(7);
  for (int ranks : {3, 5}) {
    const Decomposition d = split(g, xd, ranks);
    for (int me = 0; me < ranks; ++me) {
      RankSelector<T> sel(b);
      sel.set(d, me);
      exec::DeviceBuffer<Vec3<T>> bx(b, 0, "test.x");
      exec::DeviceBuffer<T> bm(b, 0, "test.m");
      bx.assign(x);
      bm.assign(m);
      const std::size_t n = x.size() - 100; // only the first n are looked at
      const auto got = sel.departures(bx, bm, n, vec_cast<T>(lo), vec_cast<T>(hi), walls);
      // The host's rule (RankExchange's before it moved to the backend).
      std::vector<std::uint32_t> index;
      std::vector<int> to;
      std::uint64_t removed = 0;
      double mass = 0;
      for (std::size_t i = 0; i < n; ++i) {
        bool out = false;
        for (int a = 0; a < 3; ++a) {
          const T c = (&x[i].x)[a];
          out = out || (!walls[2 * a] && c < T((&lo.x)[a])) ||
                (!walls[2 * a + 1] && c > T((&hi.x)[a]));
        }
        const int dest = out ? -1 : d.owner(vec_cast<double>(x[i]));
        if (dest == me)
          continue;
        index.push_back(static_cast<std::uint32_t>(i));
        to.push_back(dest);
        if (dest < 0) {
          ++removed;
          mass += double(m[i]);
        }
      }
      ASSERT_EQ(got.leaving.n, n);
      EXPECT_EQ(got.leaving.index, index) << ranks << " ranks, rank " << me;
      EXPECT_EQ(got.leaving.to, to) << ranks << " ranks, rank " << me;
      EXPECT_EQ(got.removed, removed);
      EXPECT_EQ(got.removed_mass, mass); // the same sum in the same order
      EXPECT_GT(removed, 0u) << "no point left through an open side: the test tests little";
      EXPECT_GT(index.size(), removed) << "no point moves to another rank";
    }
  }
}

/// Cells of `cell` over [lo, hi], about a third of them flagged (seeded): "beside walls".
template <typename T>
struct FlaggedCells {
  GridGeometry<T> geo;
  std::vector<std::uint8_t> flags;
  FlaggedCells(const Vec3d& lo, const Vec3d& hi, double cell, std::uint32_t seed) {
    geo.origin = vec_cast<T>(lo);
    geo.cell = T(cell);
    geo.inv_cell = T(1) / geo.cell;
    geo.nx = int(std::ceil((hi.x - lo.x) / cell));
    geo.ny = int(std::ceil((hi.y - lo.y) / cell));
    geo.nz = int(std::ceil((hi.z - lo.z) / cell));
    std::mt19937 rng(seed);
    flags.resize(geo.cells());
    for (auto& f : flags)
      f = rng() % 3 == 0 ? 1 : 0;
  }
  /// Point q's cell flag, from its coordinates (points outside take the nearest edge cell).
  std::uint8_t at(const Vec3<T>& q) const {
    int c[3];
    const int n[3] = {geo.nx, geo.ny, geo.nz};
    for (int d = 0; d < 3; ++d) {
      const double u = std::floor(double((&q.x)[d] - (&geo.origin.x)[d]) / double(geo.cell));
      c[d] = std::clamp(int(u), 0, n[d] - 1);
    }
    return flags[std::size_t(c[0]) + std::size_t(n[0]) * (c[1] + std::size_t(n[1]) * c[2])];
  }
};

/// wider_width > 0: the points in flagged cells (FlaggedCells) go as far as wider_width.
template <typename T>
std::size_t ghosts_are_select_ghosts(exec::Backend b, int ranks, const std::vector<double>& widths,
                                     std::size_t points = 9000, double wider_width = 0) {
  // Two thirds piled into one corner, so the parts are uneven in shape.
  const Vec3d lo{0, 0, 0}, hi{0.8, 0.4, 0.6};
  const BlockGrid g(lo, hi, 0.05);
  auto xd = uniform_points(points * 2 / 3, lo, {0.4, 0.4, 0.3}, 3);
  const auto spread = uniform_points(points - xd.size(), lo, hi, 4);
  xd.insert(xd.end(), spread.begin(), spread.end());
  const Decomposition d = split(g, xd, ranks);
  const FlaggedCells<T> cells(lo, hi, 0.02, 5);
  exec::DeviceBuffer<std::uint8_t> cell_flags(b, 0, "test.cells");
  cell_flags.assign(cells.flags);
  std::size_t sent = 0;
  for (int me = 0; me < ranks; ++me) {
    // This rank's points, in the precision the particles are held in.
    std::vector<Vec3<T>> mine;
    std::vector<Vec3d> mine_d;
    for (const Vec3d& q : xd)
      if (d.owner(q) == me) {
        mine.push_back(vec_cast<T>(q));
        mine_d.push_back(vec_cast<double>(mine.back()));
      }
    RankSelector<T> sel(b);
    sel.set(d, me);
    exec::DeviceBuffer<Vec3<T>> bx(b, 0, "test.x");
    bx.assign(mine);
    std::vector<std::uint8_t> beside;
    WiderCells<T> wider;
    if (wider_width > 0) {
      for (const auto& q : mine)
        beside.push_back(cells.at(q));
      wider = {cells.geo, cell_flags.data(), wider_width};
    }
    for (double w : widths) {
      const GhostLists want = select_ghosts(d, me, mine_d, w, beside, wider_width);
      // The lists held by the backend's copier (on a device: chosen and kept there), on a
      // selector whose scratch grows here (a stale pointer into it once went unnoticed).
      const auto rows = make_rows(b);
      const auto held = sel.ghost_rows(bx, mine.size(), w, *rows, nullptr, wider);
      EXPECT_EQ(held.peers, want.peers) << ranks << " ranks, rank " << me << ", width " << w;
      EXPECT_EQ(held.send.size(), want.send.size());
      for (std::size_t k = 0; k < std::min(want.send.size(), held.send.size()); ++k) {
        EXPECT_EQ(rows->rows_of(held.send[k]), want.send[k])
            << ranks << " ranks, rank " << me << ", width " << w << ", peer " << k;
        sent += held.send[k].size();
      }
    }
  }
  return sent;
}

} // namespace

TEST(RankSelector, DeparturesAreTheHostsOwnersAndOpenSides) {
  for (exec::Backend b : backends()) {
    SCOPED_TRACE(std::string(exec::to_string(b)));
    departures_are_the_hosts<float>(b);
    departures_are_the_hosts<double>(b);
  }
}

// A re-partition's counts, made where the particles are: each block's are the host's count of
// the points BlockGrid::block_of puts in it (points outside the box clamped into its edge blocks),
// only the flagged ones where flags are given, with every block counted (none left stale).
TEST(RankSelector, BlockCountsAreTheHostsCounts) {
  const BlockGrid g({0, 0, 0}, {0.6, 0.3, 0.4}, 0.05);
  const auto xd = uniform_points(30000, {-0.03, -0.03, -0.03}, {0.63, 0.33, 0.43}, 9);
  std::vector<std::uint32_t> only(xd.size());
  for (std::size_t i = 0; i < only.size(); ++i)
    only[i] = (i * 7919) % 3 != 0;
  for (exec::Backend b : backends()) {
    SCOPED_TRACE(std::string(exec::to_string(b)));
    const Decomposition d = split(g, xd, 3);
    RankSelector<float> sel(b);
    sel.set(d, 1);
    exec::DeviceBuffer<Vec3<float>> x(b, 0, "test.x");
    x.assign(test::vec_cast_all<float>(xd));
    exec::DeviceBuffer<std::uint32_t> flags(b, 0, "test.only");
    flags.assign(only);
    for (bool flagged : {false, true}) {
      std::vector<std::uint32_t> want(std::size_t(g.count()), 0);
      for (std::size_t i = 0; i < xd.size(); ++i)
        if (!flagged || only[i])
          ++want[std::size_t(g.block_of(vec_cast<double>(vec_cast<float>(xd[i]))))];
      // Twice: the second call finds the counts of the first and must start from zero.
      for (int round = 0; round < 2; ++round)
        EXPECT_EQ(sel.block_counts(x, xd.size(), flagged ? flags.data() : nullptr), want)
            << (flagged ? "flagged" : "all") << ", round " << round;
    }
  }
}

// Widths below, at and above a block edge (0.05): one and two blocks of reach.
TEST(RankSelector, GhostsAreSelectGhostsLists) {
  for (exec::Backend b : backends()) {
    SCOPED_TRACE(std::string(exec::to_string(b)));
    for (int ranks : {2, 3, 7}) {
      const std::size_t sent = ghosts_are_select_ghosts<float>(b, ranks, {0.013, 0.05, 0.071});
      EXPECT_GT(sent, 1000u) << "too few ghosts for the check to mean much";
      ghosts_are_select_ghosts<double>(b, ranks, {0.013, 0.071});
    }
  }
}

// The fluid beside walls goes farther (RankExchange: the ghost walls' pressures computed where
// they are): the points in flagged cells take the wider width, the others theirs; the peers are
// those within the wider width. A wider width of two blocks' reach over one, and one no wider.
TEST(RankSelector, PointsInFlaggedCellsGoFarther) {
  for (exec::Backend b : backends()) {
    SCOPED_TRACE(std::string(exec::to_string(b)));
    for (int ranks : {2, 3, 7}) {
      const std::size_t plain = ghosts_are_select_ghosts<float>(b, ranks, {0.013, 0.03});
      const std::size_t wider =
          ghosts_are_select_ghosts<float>(b, ranks, {0.013, 0.03}, 9000, 0.071);
      // About a third of the points flagged, going 2-5x as far: clearly more ghosts.
      EXPECT_GT(wider, plain + plain / 4) << ranks << " ranks";
      ghosts_are_select_ghosts<double>(b, ranks, {0.026}, 9000, 0.052);
      // No wider than the width: the plain lists.
      EXPECT_EQ(ghosts_are_select_ghosts<float>(b, ranks, {0.03}, 9000, 0.02),
                ghosts_are_select_ghosts<float>(b, ranks, {0.03}));
    }
  }
}

// 80 ranks on small blocks and a width across the whole box: every rank has more than 64
// neighbours, so the ghosts are chosen in two windows of peers.
TEST(RankSelector, MoreThan64NeighboursTakeSeveralWindows) {
  for (exec::Backend b : backends()) {
    SCOPED_TRACE(std::string(exec::to_string(b)));
    const std::size_t sent = ghosts_are_select_ghosts<float>(b, 80, {1.2}, 600);
    // Every point goes to every other rank (each holds blocks: METIS leaves no part empty here).
    EXPECT_EQ(sent, std::size_t(600) * 79);
  }
}
