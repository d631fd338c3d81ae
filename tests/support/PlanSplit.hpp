#pragma once
// `knitflow plan --ranks N` (Simulation::plan_split, one process) against a run's start on this
// job's ranks (MPI tests).
#include "comm/MpiContext.hpp"
#include "domain/Simulation.hpp"

#include <gtest/gtest.h>
#include <mpi.h>

#include <cstdio>
#include <vector>

namespace kf::test {

/// Each rank owns what the plan says it owns, of every phase, and grids the window the plan
/// gives it. The plan and the run share their rules (domain/RankLayout); before they did, the
/// plan cut blocks of support radii where the run cut blocks of the fluid's ghost width (the
/// support plus the "verlet" lists' skin, or the coupling's reach), and took the knit's width by
/// a rule of its own.
inline void expect_plan_is_the_runs_split(const Scene& s, const char* what) {
  comm::MpiContext mpi;
  const PartitionReport plan = Simulation::plan_split(s, mpi.size());
  auto run = Simulation::create(s, exec::Backend::Cpu, &mpi);
  const auto r = run->rank_report();
  const RankShare& mine = plan.rank[mpi.rank()];
  for (int p = 0; p < kPhases; ++p)
    EXPECT_EQ(r.owned[p], mine.owned[p]) << what << ": phase " << p << " on rank " << mpi.rank();
  EXPECT_EQ(r.grid_cells, mine.grid_cells) << what << " on rank " << mpi.rank();
  EXPECT_EQ(r.domain_cells, plan.domain_cells) << what;
  // The split is not the trivial one: every rank owns some of the fluid or the knit.
  EXPECT_GT(mine.owned[static_cast<int>(Phase::Fluid)] + mine.owned[static_cast<int>(Phase::Knit)],
            0u)
      << what << " on rank " << mpi.rank();
}

/// `knitflow plan --ranks N`'s memory a rank (rank_bytes) against what the run's rank holds by
/// the same measure (Simulation::memory_bytes) after its first step (the coupling's lists are
/// built in it), as close as plan's one-rank figure is to the one-rank run's: the ratio
/// estimate / held on each rank within `spread` of one rank's (a split estimate no worse than
/// the whole's). Prints the ratios on rank 0.
inline void expect_plan_memory_is_the_runs(const Scene& s, const char* what, double spread) {
  comm::MpiContext mpi;
  const PlanReport plan = Simulation::plan(s);
  const auto held_after_a_step = [](Simulation& sim) {
    sim.step(1e9);
    return double(sim.memory_bytes());
  };
  const double one =
      double(plan.bytes()) / held_after_a_step(*Simulation::create(s, exec::Backend::Cpu));
  const PartitionReport split = Simulation::plan_split(s, mpi.size());
  auto run = Simulation::create(s, exec::Backend::Cpu, &mpi);
  const double mine =
      rank_bytes(plan, split.rank[mpi.rank()], mpi.size()) / held_after_a_step(*run);
  std::vector<double> all(mpi.size());
  MPI_Allgather(&mine, 1, MPI_DOUBLE, all.data(), 1, MPI_DOUBLE, mpi.comm());
  if (mpi.root()) {
    std::printf("%s: plan's memory over the run's, one rank %.3f; on %d ranks", what, one,
                mpi.size());
    for (double a : all)
      std::printf(" %.3f", a);
    std::printf("\n");
  }
  EXPECT_NEAR(mine / one, 1.0, spread) << what << " on rank " << mpi.rank();
}

} // namespace kf::test
