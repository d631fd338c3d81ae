#pragma once
// `knitflow plan --ranks N` (Simulation::plan_split, one process) against a run's start on this
// job's ranks (MPI tests).
#include "comm/MpiContext.hpp"
#include "domain/Simulation.hpp"

#include <gtest/gtest.h>

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

} // namespace kf::test
