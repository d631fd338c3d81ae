// The knit on N ranks (mpiexec -n 2 and 3): a knit scene run split in space and on one rank
// (each rank runs the one-rank reference itself), the owned points of all ranks gathered and
// matched by id every few steps:
// - every knit point is owned by exactly one rank;
// - positions and velocities equal the one-rank run's bit for bit. A point gathers its springs
//   and volume cells in the mesh's order whichever rank holds them, and the self-contact grid
//   sorts the points in id order for the reference positions the one-rank run sorted them for
//   (carried with the points; its motion readings are the job's), so every pair list is the
//   one-rank run's. Measured: identical for 2 and 3 ranks, float and double;
// - the ghosts a rank receives are exactly the knit points of other ranks within the ghost width
//   of its region (a brute-force distance to its blocks), carrying their owners' values, and
//   include every spring and volume-cell partner of its owned points;
// - the job's diagnostics are the reference's (energies summed over ranks in another order:
//   1e-12; contact counts exactly);
// - a snapshot written by N ranks continues on one and on N, one written by one rank on N, each
//   ending where the uninterrupted one-rank run ends.
#include "comm/MpiContext.hpp"
#include "domain/KnitHalo.hpp"
#include "domain/RankExchange.hpp"
#include "domain/Simulation.hpp"
#include "io/SnapshotReader.hpp"
#include "io/SnapshotWriter.hpp"
#include "support/CouplingScenes.hpp"
#include "support/KnitScenes.hpp"
#include "support/MpiGather.hpp"
#include "support/PlanSplit.hpp"
#include "support/RestartCases.hpp"
#include "support/RowsById.hpp"
#include "support/StartPeaks.hpp"
#include "support/TestPaths.hpp"

#include <gtest/gtest.h>
#include <mpi.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <numeric>
#include <set>

using namespace kf;

namespace {

/// The knit's owned points of a frame, gathered from every rank when split, in id order.
using KnitRows = test::RowsById;
KnitRows knit_rows(const io::Frame& fr, bool gather, const char* phase = "knit") {
  return test::rows_by_id(fr, phase, gather,
                          {"position", "velocity", "mass", "density", "saturation"});
}

void expect_same_rows(const KnitRows& a, const KnitRows& b, const std::string& what) {
  ASSERT_EQ(a.id, b.id) << what << ": a knit point is owned by no rank or by two";
  for (const auto& [name, bytes] : a.bytes) {
    const auto& other = b.bytes.at(name);
    if (bytes == other)
      continue;
    // The first row that differs, for the message.
    const std::size_t row = a.id.empty() ? 1 : bytes.size() / a.id.size();
    std::size_t k = 0;
    while (k + 1 < a.id.size() &&
           std::memcmp(bytes.data() + k * row, other.data() + k * row, row) == 0)
      ++k;
    ADD_FAILURE() << what << ": " << name << " differs, first at id " << a.id[k];
  }
}

void expect_same_knit_run(const Scene& s, int steps, int every, const std::string& what,
                          std::uint64_t min_self_contacts, bool migrates,
                          exec::Backend backend = exec::Backend::Cpu) {
  comm::MpiContext mpi;
  auto one = Simulation::create(s, backend);
  auto split = Simulation::create(s, backend, &mpi);
  const io::Frame start = split->frame();
  const KnitRows first = knit_rows(start, true);
  ASSERT_EQ(first.ranks.size(), std::size_t(mpi.size())) << what << ": a rank holds no knit";
  std::uint64_t most_self = 0;
  for (int k = 1; k <= steps; ++k) {
    one->step(1e9);
    split->step(1e9);
    ASSERT_EQ(one->time(), split->time()) << what << ": the ranks took another dt, step " << k;
    if (k % every != 0 && k != steps)
      continue;
    SCOPED_TRACE(what + ", step " + std::to_string(k));
    expect_same_rows(knit_rows(one->frame(), false), knit_rows(split->frame(), true), what);
    const Diagnostics d1 = one->diagnostics(), d2 = split->diagnostics();
    EXPECT_EQ(d1.knit, d2.knit);
    EXPECT_EQ(d1.knit_contacts, d2.knit_contacts) << "contacts with solids";
    EXPECT_EQ(d1.knit_self_contacts, d2.knit_self_contacts);
    EXPECT_EQ(d1.knit_self_min_gap, d2.knit_self_min_gap);
    // Sums of ~10^3 terms over ranks in another order: a few ulps of the total.
    const auto near = [](double a, double b) { return std::abs(a - b) <= 1e-12 * std::abs(a); };
    EXPECT_TRUE(near(d1.knit_kinetic_energy, d2.knit_kinetic_energy))
        << d1.knit_kinetic_energy << " " << d2.knit_kinetic_energy;
    EXPECT_TRUE(near(d1.knit_elastic_energy, d2.knit_elastic_energy))
        << d1.knit_elastic_energy << " " << d2.knit_elastic_energy;
    EXPECT_TRUE(near(d1.knit_self_energy, d2.knit_self_energy))
        << d1.knit_self_energy << " " << d2.knit_self_energy;
    most_self = std::max(most_self, d2.knit_self_contacts);
  }
  // Points crossed between ranks (migration was exercised).
  const auto ranks_of = [](const io::Frame& fr) {
    const io::Phase& f = *fr.find("knit");
    const auto id = test::allgather(f.find("id")->as<std::uint64_t>());
    const auto rk = test::allgather(f.find("rank")->as<std::uint32_t>());
    std::vector<std::uint32_t> out(id.size());
    for (std::size_t k = 0; k < id.size(); ++k)
      out[id[k]] = rk[k];
    return out;
  };
  const auto before = ranks_of(start), after = ranks_of(split->frame());
  std::size_t moved = 0;
  for (std::size_t k = 0; k < before.size(); ++k)
    moved += before[k] != after[k];
  if (migrates) {
    EXPECT_GT(moved, 0u) << what << ": no knit point changed rank";
  }
  EXPECT_GE(most_self, min_self_contacts) << what << ": the folds never touched";
  if (mpi.root())
    std::printf("%s: %d steps to t = %.4f s, %zu knit points, %zu changed rank, up to %llu "
                "self-contacts; identical on %d ranks\n",
                what.c_str(), steps, split->time(), one->diagnostics().knit, moved,
                static_cast<unsigned long long>(most_self), mpi.size());
}

/// The paper's drape, small: a 24 x 24 square 1 cm above the ball; blocks small enough that
/// every rank holds part of it.
Scene small_drape(const std::string& precision) {
  return load_scene((test::source_dir() / "scenes" / "drape.toml").string(),
                    {"output.enabled=false", "knit.piece.0.wales=24", "knit.piece.0.courses=24",
                     "knit.piece.0.center=[0.02, 0.01, 0.51]", "parallel.block_cells=1",
                     "simulation.precision=\"" + precision + "\""});
}

} // namespace

TEST(DistributedKnit, DrapeIsTheOneRankRun) {
  // It falls onto the ball and slides a little: the ranks' blocks split it across, not along
  // its fall, so few points change rank (the folding strip's do).
  expect_same_knit_run(small_drape("float"), 3000, 500, "drape, float", 0, false);
  expect_same_knit_run(small_drape("double"), 3000, 1000, "drape, double", 0, false);
}

// No rank's backend holds the whole knit's topology (KnitSystem's `shared`): the mesh's springs
// and cells stay on the host, each rank's backend holds its points' rows. The drape at 96 x 96
// stitches (27,939 points), no self-collision (its grid covers the room whatever the knit).
TEST(DistributedKnit, NoRankHoldsTheWholeKnit) {
  comm::MpiContext mpi;
  const Scene s = load_scene((test::source_dir() / "scenes" / "drape.toml").string(),
                             {"output.enabled=false", "knit.piece.0.wales=96",
                              "knit.piece.0.courses=96", "knit.self_collision=false"});
  const test::StartPeaks p = test::start_peaks(s, mpi);
  const double most = p.largest(), one = p.one;
  // Measured (the partition and the allocations are deterministic): the largest rank 0.57 of one
  // rank's peak on 2 ranks, 0.38 on 3; with the whole knit's room kept in the set's columns after
  // distribute (until 2026-12-05) 0.65 and 0.49; with the whole mesh's cells' corners and
  // constants on every backend (until 2026-12-04, sixth) 0.73 and 0.59; with the whole mesh's
  // rows on every backend (the rows of the whole knit built, then its share gathered from
  // them), 1.61 and 1.47. A rank holds more than its share: the whole set until distribute
  // keeps its points, a slot a mesh cell (the cells its rows name compacted), its ghosts.
  EXPECT_LT(most, (mpi.size() == 2 ? 0.6 : 0.42) * one);
}

// Nor the self-contact's grid over the whole room: each rank's covers its window (fit at the
// first choice of ghosts), from the start. The drape at 96 x 96 stitches with self-collision, in
// a room 3 m wide (a grid of 4M cells, its cap: 48 MB of tables, most of one rank's peak).
TEST(DistributedKnit, NoRankHoldsTheRoomsSelfContactGrid) {
  comm::MpiContext mpi;
  const Scene s =
      load_scene((test::source_dir() / "scenes" / "drape.toml").string(),
                 {"output.enabled=false", "knit.piece.0.wales=96", "knit.piece.0.courses=96",
                  "domain.min=[-1.5,-1.5,0]", "domain.max=[1.5,1.5,1]"});
  const test::StartPeaks p = test::start_peaks(s, mpi);
  // Measured (deterministic): the largest rank 0.64 of one rank's peak on 2 ranks, 0.50 on 3;
  // with the room's grid made on every rank until the first choice (before 2026-12-05) 0.83 and
  // 0.79. A window is more than a rank's share of the room: its region and its ghosts' reach.
  EXPECT_LT(p.largest(), (mpi.size() == 2 ? 0.7 : 0.55) * p.one);
}

namespace {

/// test_knit_fold's strip, shorter, dropped from 10 cm: it crumples onto the floor in folds that
/// land on each other, so the self-contact pairs cross ranks.
Scene fold(const std::string& precision) {
  Scene s = test::falling_strip(0.3, 45, 0.1);
  s.precision = precision == "double" ? Precision::Double : Precision::Float;
  s.parallel.block_cells = 1;
  return s;
}

} // namespace

TEST(DistributedKnit, FoldingStripIsTheOneRankRun) {
  expect_same_knit_run(fold("float"), 12000, 2000, "folding strip, float", 1, true);
}

TEST(DistributedKnit, GhostsAreThePointsWithinTheWidthAndEveryPartner) {
  comm::MpiContext mpi;
  const Scene s = fold("double");
  const exec::Exec ex{exec::Backend::Cpu};
  KnitSystem<double> whole(s, ex), knit(s, ex, true); // whole: the reference, never split
  const KnitMesh mesh = build_knit(s);                // the partners, from the builder's lists
  const auto all_x = whole.set().x.to_host();
  const auto all_m = whole.set().m.to_host();
  RankExchange<double> ranks(mpi, s, exec::Backend::Cpu,
                             SplitInputs{KnitHalo<double>::base_width(knit)});
  ranks.distribute(nullptr, nullptr, all_x);
  // A knit built for one rank holds its rows on the backend only: sharing it is refused.
  EXPECT_THROW(KnitHalo<double>(ranks, whole), Error);
  KnitHalo<double> halo(ranks, knit);
  halo.distribute();
  halo.begin(0.0);
  const Decomposition& d = ranks.decomposition();
  const auto& set = knit.set();
  const std::size_t owned = halo.owned(), n = set.size();
  const auto id = set.id.to_host();
  const auto x = set.x.to_host();
  const auto m = set.m.to_host();
  std::vector<std::uint64_t> want;
  for (std::size_t i = 0; i < all_x.size(); ++i) {
    const bool mine = d.owner(all_x[i]) == mpi.rank();
    if (!mine && d.distance_to_region(all_x[i], mpi.rank()) < halo.width())
      want.push_back(i);
  }
  std::vector<std::uint64_t> got(id.begin() + owned, id.end());
  std::sort(got.begin(), got.end());
  EXPECT_EQ(got, want) << "rank " << mpi.rank() << ", width " << halo.width();
  EXPECT_GT(got.size(), 0u);
  // Owned: exactly the points in this rank's blocks; ids over all ranks each once.
  for (std::size_t k = 0; k < owned; ++k)
    EXPECT_EQ(d.owner(all_x[id[k]]), mpi.rank()) << "point " << id[k];
  auto ids = test::allgather(std::vector<std::uint64_t>(id.begin(), id.begin() + owned));
  std::sort(ids.begin(), ids.end());
  std::vector<std::uint64_t> every(all_x.size());
  std::iota(every.begin(), every.end(), 0u);
  EXPECT_EQ(ids, every);
  // Each ghost carries its point's values; every partner of an owned point is here.
  for (std::size_t k = 0; k < n; ++k) {
    EXPECT_EQ(std::memcmp(&x[k], &all_x[id[k]], sizeof(x[k])), 0) << "point " << id[k];
    EXPECT_EQ(m[k], all_m[id[k]]);
  }
  std::set<std::uint64_t> here(id.begin(), id.end()), owned_ids(id.begin(), id.begin() + owned);
  std::size_t partners = 0, remote = 0;
  for (const Spring& sp : mesh.springs)
    for (auto [a, b] : {std::pair{sp.i, sp.j}, std::pair{sp.j, sp.i}})
      if (owned_ids.count(a)) {
        ++partners;
        remote += !owned_ids.count(b);
        EXPECT_TRUE(here.count(b)) << "spring partner " << b << " of owned point " << a;
      }
  for (const VolumeCell& c : mesh.volumes)
    for (auto a : c.point)
      if (owned_ids.count(a)) {
        for (auto b : c.point)
          EXPECT_TRUE(here.count(b)) << "cell partner " << b << " of owned point " << a;
      }
  EXPECT_GT(remote, 0u) << "no spring crosses ranks: the check saw nothing";
  // The self-contact's grid covers this rank's region and its ghosts, not the room: fewer
  // cells, every point here inside it (none clamped to an edge cell: the lists stay the
  // one-rank run's).
  const auto* self = knit.self_contact();
  ASSERT_NE(self, nullptr) << "the folding strip collides with itself";
  const auto& g = self->grid();
  EXPECT_LT(g.cells(), self->whole_grid().cells());
  for (std::size_t k = 0; k < n; ++k) {
    const int c[3] = {int(std::floor((x[k].x - g.origin.x) * g.inv_cell)) - g.ox,
                      int(std::floor((x[k].y - g.origin.y) * g.inv_cell)) - g.oy,
                      int(std::floor((x[k].z - g.origin.z) * g.inv_cell)) - g.oz};
    EXPECT_TRUE(c[0] >= 0 && c[0] < g.nx && c[1] >= 0 && c[1] < g.ny && c[2] >= 0 && c[2] < g.nz)
        << "point " << id[k] << " outside the grid's window";
  }
  if (mpi.root())
    std::printf("rank 0: %zu owned knit points, %zu ghosts within %.4f m; %zu spring ends, %zu "
                "of them on another rank\n",
                owned, n - owned, halo.width(), partners, remote);
}

// The springs' and the cells' rows travel with their points: no rank's host builds or keeps the
// whole knit's.
// The strip mirrored through the room's centre (most points change rank), then the ghosts chosen
// anew: each rank's rows are exactly its owned points', in the set's order, each row the one a
// build of the whole mesh gives that point, to the bit.
TEST(DistributedKnit, TheRowsTravelWithTheirPoints) {
  comm::MpiContext mpi;
  const Scene s = fold("double");
  const exec::Exec ex{exec::Backend::Cpu};
  KnitSystem<double> knit(s, ex, true);
  const KnitMesh mesh = build_knit(s);
  const std::size_t n = mesh.x.size();
  std::vector<std::uint64_t> every(n);
  std::iota(every.begin(), every.end(), std::uint64_t(0));
  const auto whole = SpringTopology<double>::host_rows(ex.backend, mesh.springs, n, every);
  std::vector<std::uint32_t> cell_index(mesh.volumes.size());
  std::iota(cell_index.begin(), cell_index.end(), 0u);
  const auto whole_cells =
      VolumeTopology<double>::host_rows(ex.backend, mesh.volumes, cell_index, n, every);
  RankExchange<double> ranks(mpi, s, exec::Backend::Cpu,
                             SplitInputs{KnitHalo<double>::base_width(knit)});
  ranks.distribute(nullptr, nullptr, knit.set().x.to_host());
  KnitHalo<double> halo(ranks, knit);
  halo.distribute();
  ASSERT_NE(knit.host_rows(), nullptr);
  EXPECT_LT(knit.host_rows()->points(), n) << "a rank's host took the whole knit's rows";
  halo.begin(0.0);
  const auto check = [&](const char* when) {
    const auto id = knit.set().id.to_host();
    const std::size_t owned = halo.owned();
    const auto* rows = knit.host_rows();
    ASSERT_EQ(rows->points(), owned) << when;
    EXPECT_EQ(rows->width, whole.width) << when << ": a migration moves rows of one width";
    EXPECT_TRUE(std::equal(id.begin(), id.begin() + owned, knit.row_ids().begin())) << when;
    EXPECT_EQ(rows->springs, whole.springs) << when;
    const SpringView<double> mine = rows->view(), all = whole.view();
    std::size_t entries = 0;
    for (std::size_t k = 0; k < owned; ++k) {
      ASSERT_EQ(mine.count[k], all.count[id[k]]) << when << ": point " << id[k];
      for (std::uint32_t e = 0; e < mine.count[k]; ++e, ++entries) {
        const auto &a = mine.entry[mine.rows.at(e, k)], &b = all.entry[all.rows.at(e, id[k])];
        ASSERT_TRUE(a.other == b.other && a.rest == b.rest && a.k == b.k && a.c == b.c)
            << when << ": point " << id[k] << "'s spring " << e;
      }
    }
    const auto* cells = knit.host_cell_rows();
    ASSERT_EQ(cells->points(), owned) << when;
    EXPECT_EQ(cells->width, whole_cells.width) << when;
    std::size_t corners = 0;
    for (std::size_t k = 0; k < owned; ++k) {
      ASSERT_EQ(cells->count[k], whole_cells.count[id[k]]) << when << ": point " << id[k];
      for (std::uint32_t e = 0; e < cells->count[k]; ++e, ++corners)
        ASSERT_EQ(cells->cell[cells->rows().at(e, k)],
                  whole_cells.cell[whole_cells.rows().at(e, id[k])])
            << when << ": point " << id[k] << "'s cell " << e;
    }
    // Every point's rows on exactly one rank.
    std::uint64_t counts[3] = {owned, entries, corners};
    MPI_Allreduce(MPI_IN_PLACE, counts, 3, MPI_UINT64_T, MPI_SUM, mpi.comm());
    EXPECT_EQ(counts[0], n) << when;
    EXPECT_EQ(counts[1], 2 * whole.springs) << when;
    EXPECT_EQ(counts[2], 4 * mesh.volumes.size()) << when;
    EXPECT_GT(counts[2], 0u) << "the strip has no volume cells: a weak case";
  };
  check("after the first choice");
  // Every point mirrored through the room's centre: the points go to the ranks across.
  auto x = knit.set().x.to_host();
  const std::size_t owned_before = halo.owned();
  std::size_t moved = 0;
  const Decomposition& d = ranks.decomposition();
  for (std::size_t k = 0; k < owned_before; ++k) {
    x[k] = Vec3d{s.domain.min.x + s.domain.max.x - x[k].x, s.domain.min.y + s.domain.max.y - x[k].y,
                 s.domain.min.z + s.domain.max.z - x[k].z};
    moved += d.owner(x[k]) != mpi.rank();
  }
  knit.set().x.assign(x);
  halo.begin(1e9); // far past the skin: migration and a new choice
  check("after a migration");
  std::uint64_t changed = moved;
  MPI_Allreduce(MPI_IN_PLACE, &changed, 1, MPI_UINT64_T, MPI_SUM, mpi.comm());
  EXPECT_GT(changed, n / 4) << "too few points changed rank: the migration went untested";
  if (mpi.root())
    std::printf("the springs' and cells' rows: %llu of %zu points changed rank, each rank's rows "
                "its own\n",
                static_cast<unsigned long long>(changed), n);
}

// Restart across rank counts with the knit: a snapshot written by N ranks (self-contacts
// present) continues on N ranks and on one, one written by one rank on N; each continuation
// ends where the uninterrupted one-rank run ends, bit for bit.
TEST(DistributedKnit, RestartContinuesOnAnyRankCount) {
  comm::MpiContext world;
  const Scene s = fold("float");
  const int first = 10000, total = 11000;
  const test::OneRankRun one = test::one_rank_run(s, first, total);
  const KnitRows want = knit_rows(one.sim->frame(), false);
  auto finish = [&](Simulation& sim, bool split) {
    EXPECT_EQ(sim.steps(), static_cast<std::uint64_t>(first));
    while (sim.steps() < static_cast<std::uint64_t>(total))
      sim.step(1e9);
    return knit_rows(sim.frame(), split);
  };
  std::uint64_t contacts = 0;
  test::restart_on_any_rank_count(
      world, s, first, one.at_first, "distributed_knit_restart",
      [&](Simulation& sim, bool split, const std::string& what) {
        expect_same_rows(want, finish(sim, split), what);
      },
      [&](Simulation& split) { contacts = split.diagnostics().knit_self_contacts; });
  EXPECT_GT(contacts, 0u) << "no self-contact at the restart: its state went untested";
  if (world.root())
    std::printf("knit restart at step %d of %d (%llu self-contacts): N -> N, N -> 1, 1 -> N all "
                "end as the one-rank run\n",
                first, total, static_cast<unsigned long long>(contacts));
}

namespace {

/// Fluid falling into a hammock of knit (contact and the paper's capillary model, test_coupling's
/// scene under gravity): the coupling's pairs cross ranks both ways.
Scene hammock(const std::string& precision) {
  return parse_scene(
      test::scene_text(R"("fluid", "boundary", "knit", "contact", "capillary")",
                       "min = [-0.03, -0.03, 0.056]\nmax = [0.03, 0.03, 0.086]", -1.0,
                       std::string("[capillary]\nsigma = 0.5\n") + test::kHammockPins),
      "<hammock>",
      {"simulation.gravity=[0, 0, -9.81]", "parallel.block_cells=1",
       "simulation.precision=\"" + precision + "\""});
}

/// Free + absorbed + outflowed fluid mass (the conserving absorption's books).
double books(const Diagnostics& d) {
  return d.fluid_mass + d.absorbed_mass + d.outflow_mass;
}

/// Whether two frames' rows (knit and fluid, by id) are the same bytes.
bool same_rows(const KnitRows& a, const KnitRows& b) {
  if (a.id != b.id)
    return false;
  for (const auto& [name, bytes] : a.bytes)
    if (bytes != b.bytes.at(name))
      return false;
  return true;
}

/// The largest distance between the positions of the ids both frames hold.
double largest_gap(const KnitRows& a, const KnitRows& b, bool doubles) {
  const auto& pa = a.bytes.at("position");
  const auto& pb = b.bytes.at("position");
  const std::size_t w = doubles ? 8 : 4;
  const auto at = [&](const std::vector<unsigned char>& p, std::size_t k) {
    if (doubles) {
      double u = 0;
      std::memcpy(&u, &p[k * w], 8);
      return u;
    }
    float u = 0;
    std::memcpy(&u, &p[k * w], 4);
    return double(u);
  };
  double gap = 0;
  for (std::size_t i = 0, j = 0; i < a.id.size() && j < b.id.size();) {
    if (a.id[i] < b.id[j]) {
      ++i;
    } else if (b.id[j] < a.id[i]) {
      ++j;
    } else {
      for (std::size_t c = 0; c < 3; ++c)
        gap = std::max(gap, std::abs(at(pa, 3 * i + c) - at(pb, 3 * j + c)));
      ++i, ++j;
    }
  }
  return gap;
}

/// may_part: the runs may part at rounding level (on the GPU: the lanes of a knit point share
/// its fluid candidates by place in the cell walk, and on N ranks a cell at the ghosts' edge
/// holds only some of its particles, so a knit point near a rank's border may sum in other
/// shares; see test_coupling_K's KnitSideIgnoresFluidOutOfReach). From the first difference
/// on, the split run must stay as close to the one-rank run as a one-rank run summing in
/// another order (solver.cell_order = 0: a cell's particles by id, not by sub-cell) stays to it,
/// both run to the same time; the books are checked throughout.
/// Returns the tunnelling guard's corrections over the split job's run.
std::uint64_t expect_same_coupled_run(const Scene& s, int steps, int every, const std::string& what,
                                      bool may_part = false,
                                      exec::Backend backend = exec::Backend::Cpu) {
  comm::MpiContext mpi;
  auto one = Simulation::create(s, backend);
  auto split = Simulation::create(s, backend, &mpi);
  const bool conserving = s.capillary.model == Scene::AbsorptionModel::Conserving;
  const bool doubles = s.precision == Precision::Double;
  const double m0 = books(split->diagnostics());
  std::uint64_t contacts = 0;
  double wet = 0, drift = 0;
  int parted = 0;
  for (int k = 1; k <= steps && !parted; ++k) {
    one->step(1e9);
    split->step(1e9);
    if (one->time() != split->time()) {
      EXPECT_TRUE(may_part) << what << ": the ranks took another dt, step " << k;
      if (!may_part)
        return 0;
      parted = k;
      break;
    }
    if (k % every != 0 && k != steps)
      continue;
    SCOPED_TRACE(what + ", step " + std::to_string(k));
    const io::Frame f1 = one->frame(), f2 = split->frame();
    const KnitRows k1 = knit_rows(f1, false), k2 = knit_rows(f2, true);
    const KnitRows w1 = knit_rows(f1, false, "fluid"), w2 = knit_rows(f2, true, "fluid");
    const Diagnostics d1 = one->diagnostics(), d2 = split->diagnostics();
    drift = std::max(drift, std::abs(books(d2) - m0) / m0);
    contacts = std::max(contacts, d2.coupling_contacts);
    wet = std::max(wet, d2.max_saturation);
    EXPECT_EQ(k1.id, k2.id) << what << ": a knit point is owned by no rank or by two";
    if (k1.id != k2.id)
      return 0;
    if (may_part && !(same_rows(k1, k2) && same_rows(w1, w2))) {
      parted = k;
      break;
    }
    expect_same_rows(k1, k2, what + ", knit");
    expect_same_rows(w1, w2, what + ", fluid");
    EXPECT_EQ(d1.fluid, d2.fluid);
    EXPECT_EQ(d1.coupling_contacts, d2.coupling_contacts);
    EXPECT_EQ(d1.sheet_corrections, d2.sheet_corrections);
    EXPECT_EQ(d1.wet_points, d2.wet_points);
    EXPECT_EQ(d1.max_saturation, d2.max_saturation);
    // Sums over ranks in another order: a few ulps of the total.
    EXPECT_NEAR(d2.absorbed_mass, d1.absorbed_mass, 1e-12 * std::max(1e-30, d1.absorbed_mass));
    EXPECT_EQ(d1.absorbed_particles, d2.absorbed_particles);
    EXPECT_EQ(d1.emitted_particles, d2.emitted_particles);
    EXPECT_NEAR(d2.diffused_mass, d1.diffused_mass, 1e-12 * std::max(1e-30, d1.diffused_mass));
  }
  double gap = 0, reference = 0;
  if (parted) {
    // Both to the time the one-rank run reaches in `steps` steps, and a one-rank run summing
    // in another order beside them.
    for (int k = parted; k < steps; ++k)
      one->step(1e9);
    const double end = one->time();
    while (split->time() < end) {
      split->step(end);
      drift = std::max(drift, std::abs(books(split->diagnostics()) - m0) / m0);
    }
    Scene other = s;
    other.solver.cell_order = 0;
    auto noise = Simulation::create(other, backend);
    while (noise->time() < end)
      noise->step(end);
    const io::Frame f1 = one->frame(), f2 = split->frame(), fn = noise->frame();
    for (const char* phase : {"knit", "fluid"}) {
      const KnitRows a = knit_rows(f1, false, phase);
      gap = std::max(gap, largest_gap(a, knit_rows(f2, true, phase), doubles));
      reference = std::max(reference, largest_gap(a, knit_rows(fn, false, phase), doubles));
    }
    // Both part at rounding level and grow through the splash. Measured on 2 ranks: absorbing
    // hammock, double, 9.4e-13 m against 1.6e-9 m (parted at step 850 of 2,500); float
    // 7.9e-5 m against 6.7e-5 m (step 700 of 1,000).
    EXPECT_GT(reference, 0.0) << what;
    EXPECT_LE(gap, 2 * reference) << what << ": the split run strayed further than rounding";
  }
  EXPECT_GT(contacts, 0u) << what << ": the fluid never touched the knit";
  const Diagnostics d = split->diagnostics(), d_one = one->diagnostics();
  // The fluid's and the knit's phases, each rank's times summed over them: the sum of each
  // phase's slowest rank is at least the slowest rank's sum (equal where one rank is the
  // slowest in both), checked when a check has measured (imbalance 1e9: no re-partition).
  if (d.imbalance > 0) {
    EXPECT_GE(d.phase_imbalance, d.imbalance * (1 - 1e-12)) << what;
    // That sum is the phases' own spreads (slowest over their mean) weighted by each phase's
    // share of the mean compute, so it lies between the least and the most of them; both the
    // fluid and the knit were timed (the boundary is timed with the fluid).
    const double fluid = d.phase_spread[static_cast<int>(Phase::Fluid)],
                 knit = d.phase_spread[static_cast<int>(Phase::Knit)];
    EXPECT_GE(fluid, 1.0) << what;
    EXPECT_GE(knit, 1.0) << what;
    EXPECT_EQ(d.phase_spread[static_cast<int>(Phase::Boundary)], 0.0) << what;
    EXPECT_GE(d.phase_imbalance, std::min(fluid, knit) * (1 - 1e-12)) << what;
    EXPECT_LE(d.phase_imbalance, std::max(fluid, knit) * (1 + 1e-12)) << what;
  }
  if (s.solver.neighbour_list == Scene::Solver::NeighbourLists::Verlet && !parted) {
    // The coupling's lists last as on one rank (anchored at the fluid's listed positions, the
    // ghosts kept with them): built again at the same fluid sorts and knit grid sorts, which
    // every rank takes together (the knit's watch reads the job's motion). Before the anchor
    // on N ranks the split built them every step (401 against 34 in the hammock's 400 steps).
    EXPECT_EQ(d.fluid_sorts, d_one.fluid_sorts) << what;
    EXPECT_EQ(d.coupling_list_builds, d_one.coupling_list_builds)
        << what << ": the split built the coupling's lists more often than one rank";
  }
  if (conserving) {
    EXPECT_GT(d.absorbed_mass, 0.0) << what << ": nothing was absorbed";
    EXPECT_GT(d.diffused_mass, 0.0) << what << ": nothing moved inside the knit";
    // Each transfer is computed once, by one rank, and applied as the same value to both sides:
    // the split job's books drift as the one-rank run's (test_absorption: 5e-14 in double, each
    // book a double sum of ~10^3 terms). In float a particle's remaining mass m - give is
    // rounded (6e-8 of a particle's mass a partial absorption): no bound here.
    if (doubles) {
      EXPECT_LT(drift, 5e-14) << what << ": the split job lost or made fluid mass";
    }
  }
  if (mpi.root()) {
    std::printf("%s: %d steps to t = %.4f s, %zu fluid, %zu knit, up to %llu contacts, "
                "saturation up to %.3f; %llu absorbed, %llu emitted, mass drift %.1e; ",
                what.c_str(), steps, split->time(), d.fluid, d.knit,
                static_cast<unsigned long long>(contacts), wet,
                static_cast<unsigned long long>(d.absorbed_particles),
                static_cast<unsigned long long>(d.emitted_particles), drift);
    std::printf("a coupling pair weighed as %.3g knit points; ", d.pair_weight);
    std::printf("imbalance %.3f (phases' slowest summed %.3f: fluid %.3f, knit %.3f); ",
                d.imbalance, d.phase_imbalance, d.phase_spread[static_cast<int>(Phase::Fluid)],
                d.phase_spread[static_cast<int>(Phase::Knit)]);
    std::printf("coupling's lists built %llu times (one rank %llu), fluid sorted %llu (%llu); ",
                static_cast<unsigned long long>(d.coupling_list_builds),
                static_cast<unsigned long long>(d_one.coupling_list_builds),
                static_cast<unsigned long long>(d.fluid_sorts),
                static_cast<unsigned long long>(d_one.fluid_sorts));
    if (d.sheet_corrections)
      std::printf("%llu steps through the sheet put back; ",
                  static_cast<unsigned long long>(d.sheet_corrections));
    if (parted)
      std::printf("parted at step %d, largest gap %.3g m at the end against %.3g m between two "
                  "summation orders on one rank (%d ranks)\n",
                  parted, gap, reference, mpi.size());
    else
      std::printf("identical on %d ranks\n", mpi.size());
  }
  return d.sheet_corrections;
}

/// test_absorption's hammock: the conserving model under a block three times what the knit
/// holds, which it absorbs, spreads and drips.
Scene absorbing_hammock(const std::string& precision) {
  Scene s = parse_scene(
      test::scene_text(R"("fluid", "boundary", "knit", "contact", "capillary")",
                       "min = [-0.02, -0.02, 0.056]\nmax = [0.02, 0.02, 0.086]", 0.0,
                       std::string("[capillary]\nmodel = \"conserving\"\npermeability = 1e-8\n") +
                           test::kHammockPins),
      "<absorbing hammock>",
      {"simulation.gravity=[0, 0, -9.81]", "parallel.block_cells=1", "knit.substeps=4",
       "simulation.precision=\"" + precision + "\""});
  // No re-partition by measured time: the partition is the same at every run (the wicking below
  // is re-partitioned). Drops are emitted on one rank into another's region here: before P5
  // stage 10 they migrated without their acceleration and the runs parted at the first one.
  s.parallel.imbalance = 1e9;
  return s;
}

} // namespace

namespace {

/// No re-partition by measured time (as for the absorbing hammock): a partition chosen by the
/// machine's load can put two particles of one sub-cell in another order, and the runs then
/// part at rounding level (seen under load, with and without overlap: re-partitioned every 20
/// steps, the double "verlet" run parted in 3 of 6 runs). The wicking below is re-partitioned.
Scene fixed(Scene s) {
  s.parallel.imbalance = 1e9;
  return s;
}

} // namespace

TEST(DistributedKnit, CoupledPourIsTheOneRankRun) {
  if (comm::MpiContext().size() > 2) // the knit's split on 3: the drape, the strip, the restart
    GTEST_SKIP() << "two ranks in CI (three oversubscribe its two cores: 47 s)";
  expect_same_coupled_run(fixed(hammock("double")), 1000, 250, "hammock pour, double");
  expect_same_coupled_run(fixed(hammock("float")), 1000, 500, "hammock pour, float");
  // "verlet" lists (the pour's own setting): the fluid's lists kept over steps (21 sorts in 400
  // steps), the ghosts with them, and the coupling's lists as long as they are.
  Scene verlet = fixed(hammock("float"));
  verlet.solver.neighbour_list = Scene::Solver::NeighbourLists::Verlet;
  expect_same_coupled_run(verlet, 400, 200, "hammock pour, float, verlet lists");
}

// `knitflow plan --ranks N` is the run's split with the knit and its coupling too: the knit's
// width (springs, volume cells, the contact cells) and the coupling's reach widen the ghosts.
TEST(DistributedKnit, ThePlanIsTheRunsSplit) {
  test::expect_plan_is_the_runs_split(hammock("float"), "hammock pour");
  test::expect_plan_is_the_runs_split(small_drape("double"), "drape");
}

// And its memory a rank is what the run's rank holds, as nearly as its one-rank figure is.
// Measured after the first step (the coupling's lists built; plan prices their rows by its bound
// on the fluid near the knit, the run by the fluid near it then): plan over the run 1.114 /
// 1.000 on one rank (hammock / drape); on 2 ranks 1.107, 1.134 / 0.989, 0.997; on 3 1.092,
// 1.111, 1.090 / 0.901, 0.971, 0.954: within 10% of one rank's (the plan prices a rank's volume
// cells, self-contact grid and coupling rows by its points' share; its cells include the
// border's, its grid is its window's); the bound 12%.
TEST(DistributedKnit, ThePlansMemoryIsTheRunsRanks) {
  test::expect_plan_memory_is_the_runs(hammock("float"), "hammock pour", 0.12);
  test::expect_plan_memory_is_the_runs(small_drape("double"), "drape", 0.12);
}

// Restart across rank counts with the fluid coupled to the knit (the paper's capillary model):
// the restored run reports, before its first step, the saturation of the state restored (on N
// ranks the knit's points are shared out anew, so it is computed again), which is the one the
// uninterrupted run's next step begins with, and ends where that run ends, bit for bit.
TEST(DistributedKnit, CoupledRestartContinuesOnAnyRankCount) {
  comm::MpiContext world;
  if (world.size() > 2) // RestartContinuesOnAnyRankCount takes 1 -> 3 -> 1 uncoupled
    GTEST_SKIP() << "two ranks in CI (three oversubscribe its two cores: 27 s)";
  const Scene s = fixed(hammock("double"));
  const int first = 500, total = 800;
  Diagnostics next_begins; // the saturation step first + 1 begins with
  const test::OneRankRun one = test::one_rank_run(s, first, total, [&](int k, Simulation& sim) {
    if (k == first + 1)
      next_begins = sim.diagnostics();
  });
  ASSERT_GT(next_begins.wet_points, 0u)
      << "nothing wet at the restart: the saturation went untested";
  const io::Frame end = one.sim->frame();
  const KnitRows want = knit_rows(end, false), want_fluid = knit_rows(end, false, "fluid");
  test::restart_on_any_rank_count(
      world, s, first, one.at_first, "distributed_coupled_restart",
      [&](Simulation& sim, bool split, const std::string& what) {
        SCOPED_TRACE(what);
        ASSERT_EQ(sim.steps(), static_cast<std::uint64_t>(first));
        const Diagnostics d = sim.diagnostics(); // threw on N ranks: the saturation's old count
        EXPECT_EQ(d.wet_points, next_begins.wet_points);
        EXPECT_EQ(d.max_saturation, next_begins.max_saturation);
        while (sim.steps() < static_cast<std::uint64_t>(total))
          sim.step(1e9);
        const io::Frame f = sim.frame();
        expect_same_rows(want, knit_rows(f, split), what + ", knit");
        expect_same_rows(want_fluid, knit_rows(f, split, "fluid"), what + ", fluid");
      });
  if (world.root())
    std::printf("coupled restart at step %d of %d (%llu wet points, saturation up to %.3f): "
                "N -> N, N -> 1, 1 -> N all end as the one-rank run\n",
                first, total, static_cast<unsigned long long>(next_begins.wet_points),
                next_begins.max_saturation);
}

// The conserving absorption on N ranks (capillary.model = "conserving"): particles taken whole
// and in part across ranks, the absorbed fluid spreading along links between points of
// different ranks, drops emitted and numbered as on one rank.
TEST(DistributedKnit, ConservingAbsorptionIsTheOneRankRun) {
  if (comm::MpiContext().size() > 2)
    GTEST_SKIP() << "two ranks in CI (three oversubscribe its two cores: 108 s)";
  expect_same_coupled_run(absorbing_hammock("double"), 2500, 50, "absorbing hammock, double");
  expect_same_coupled_run(absorbing_hammock("float"), 1000, 50, "absorbing hammock, float");
  // scenes/wicking.toml: the strip dips into the pool at t = 0.01 s (step ~80) and soaks it up.
  // Re-partitioned every 20 steps (the knit migrating with its masses at the next choice).
  const Scene wicking =
      load_scene((test::source_dir() / "scenes" / "wicking.toml").string(),
                 {"output.enabled=false", "parallel.block_cells=1", "parallel.imbalance=1.0",
                  "parallel.check_every=20", "parallel.payback=false"});
  expect_same_coupled_run(wicking, 600, 100, "wicking");
}

// The tunnelling guard on N ranks (scenes/stress/jet.toml: a block at 10 m/s onto a pinned
// patch, thousands of steps put back): a face is tested where its particle is owned, its corners
// found through the knit's ids (ghosts included), and the split job is the one-rank run bit for
// bit, its count of corrections the same. Measured: identical on 2 and 3 ranks over 1,000 steps;
// CI runs 2 ranks (3 on its two cores: 342 s). Here the ranks' border lies away from the impact.
TEST(DistributedKnit, TunnellingGuardIsTheOneRankRun) {
  if (comm::MpiContext().size() > 2)
    GTEST_SKIP() << "two ranks in CI (three oversubscribe its two cores)";
  const Scene jet =
      fixed(load_scene((test::source_dir() / "scenes" / "stress" / "jet.toml").string(),
                       {"output.enabled=false", "parallel.block_cells=1"}));
  EXPECT_GT(expect_same_coupled_run(jet, 1000, 100, "jet"), 100u)
      << "the guard hardly acted: the case tests little";
}

// The guard's reaction across the ranks' border: the domain widened along x so that the border
// cuts through the impact, faces met by one rank's particles have corners owned by the other,
// and the reaction's per-corner counts and velocity changes travel ghost -> owner -> ghost
// (KnitHalo::add_to_owners). Without those sums the split run takes another dt at step 365
// (tried). With them the counts on every rank equal the one-rank run's and each ghost's velocity
// its owner's (checked step by step over steps 700-800), and the runs are identical to step 765;
// at 766 one fluid velocity differs in its last bit: the coupling's knit grid goes stale every
// few steps under the impact and its exact fallback sums run on the rank that saw the motion,
// not on all. Past that point the jet is chaotic (two summation orders on one rank end 3 cm apart
// at step 1000), so the test asks for identity over the first 700 steps.
TEST(DistributedKnit, TheGuardsReactionCrossesTheRanksBorder) {
  if (comm::MpiContext().size() > 2)
    GTEST_SKIP() << "two ranks in CI (three oversubscribe its two cores)";
  const Scene jet =
      fixed(load_scene((test::source_dir() / "scenes" / "stress" / "jet.toml").string(),
                       {"output.enabled=false", "parallel.block_cells=1",
                        "domain.min=[-0.2, -0.05, 0.0]", "domain.max=[0.2, 0.05, 0.3]"}));
  EXPECT_GT(expect_same_coupled_run(jet, 700, 50, "jet cut through the impact"), 100u)
      << "the guard hardly acted: the case tests little";
}

// The knit on the GPU backend (where a GPU is visible; the ranks may share one): the points stay
// on the device, the ghosts' refreshes between substeps move device rows, and the choices of
// ghosts read copies on the host. The same cases against the one-rank GPU run: the GPU's knit
// passes gather each point's springs, cells and pairs in the one-rank order, as the CPU's do.
// Measured: identical on 2 ranks (a GPU each over NCCL, and sharing one over MPI) and, for the
// knit alone, on 3 ranks sharing one.
TEST(DistributedKnit, OnTheGpuTheSplitKnitIsTheOneRankGpuRun) {
  if (!exec::cuda_available())
    GTEST_SKIP() << "no CUDA device visible";
  const auto gpu = exec::Backend::Cuda;
  expect_same_knit_run(small_drape("float"), 1500, 500, "GPU drape, float", 0, false, gpu);
  expect_same_knit_run(fold("float"), 12000, 3000, "GPU folding strip, float", 1, true, gpu);
}

// The coupled and absorbing hammocks on the GPU. They may part from the one-rank GPU run at
// rounding level (may_part: the knit side's lanes, above) and must then stay as close to it as
// a one-rank run summing in another order. Measured on one H100 (P5 stage 11, 2026-11-27): the
// double hammock pour parted on 2 ranks at step 1000 and on 3 at step 750; the float one with
// "verlet" lists and the absorbing hammock stayed identical on 2 and 3 ranks. With only the
// candidates in reach dealt to the lanes all three were identical on 2 and 3 ranks, at 6-9% of
// the pour's time: not kept.
TEST(DistributedKnit, OnTheGpuTheCoupledSplitIsTheOneRankGpuRun) {
  if (!exec::cuda_available())
    GTEST_SKIP() << "no CUDA device visible";
  const auto gpu = exec::Backend::Cuda;
  expect_same_coupled_run(fixed(hammock("double")), 1000, 250, "GPU hammock pour, double", true,
                          gpu);
  Scene verlet = fixed(hammock("float"));
  verlet.solver.neighbour_list = Scene::Solver::NeighbourLists::Verlet;
  expect_same_coupled_run(verlet, 400, 200, "GPU hammock pour, float, verlet lists", true, gpu);
}

TEST(DistributedKnit, OnTheGpuTheAbsorbingSplitIsTheOneRankGpuRun) {
  if (!exec::cuda_available())
    GTEST_SKIP() << "no CUDA device visible";
  const auto gpu = exec::Backend::Cuda;
  expect_same_coupled_run(absorbing_hammock("double"), 1500, 50, "GPU absorbing hammock, double",
                          true, gpu);
}
