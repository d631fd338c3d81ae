#pragma once
// Restart across rank counts (MPI tests): the one-rank reference run, and the continuations of
// a snapshot written collectively by N ranks (on N ranks and on one) and of a one-rank frame (on
// N ranks), each handed to the test's check at the restart step.
#include "comm/MpiContext.hpp"
#include "core/Error.hpp"
#include "domain/Simulation.hpp"
#include "io/SnapshotReader.hpp"
#include "io/SnapshotWriter.hpp"
#include "support/TestPaths.hpp"

#include <gtest/gtest.h>
#include <mpi.h>

#include <functional>
#include <memory>
#include <string>

namespace kf::test {

/// The one-rank run to `total` steps (every rank runs it) and its frame at `first`;
/// each(k, sim) after every step k.
struct OneRankRun {
  std::unique_ptr<Simulation> sim;
  io::Frame at_first;
};
inline OneRankRun one_rank_run(const Scene& s, int first, int total,
                               const std::function<void(int, Simulation&)>& each = {}) {
  OneRankRun r{Simulation::create(s, exec::Backend::Cpu), {}};
  for (int k = 1; k <= total; ++k) {
    r.sim->step(1e9);
    if (k == first)
      r.at_first = r.sim->frame();
    if (each)
      each(k, *r.sim);
  }
  return r;
}

/// The N ranks of `world` run `first` steps of s and write a snapshot into scratch_dir(name);
/// it continues on N ranks ("N ranks -> N ranks") and on one ("N ranks -> 1 rank"), and
/// one_at_first continues on N ("1 rank -> N ranks"). check(sim, split, what) gets each restored
/// run at step `first`; before_write(split) and written(frame) see the writing run and what it
/// wrote.
using RestartCheck = std::function<void(Simulation&, bool split, const std::string& what)>;
inline void restart_on_any_rank_count(const comm::MpiContext& world, const Scene& s, int first,
                                      const io::Frame& one_at_first, const std::string& name,
                                      const RestartCheck& check,
                                      const std::function<void(Simulation&)>& before_write = {},
                                      const std::function<void(const io::Frame&)>& written = {}) {
  std::string snap;
  {
    auto split = Simulation::create(s, exec::Backend::Cpu, &world);
    for (int k = 1; k <= first; ++k)
      split->step(1e9);
    if (before_write)
      before_write(*split);
    io::SnapshotWriter writer(world.comm(), scratch_dir(name).string());
    io::Frame fr = split->frame();
    fr.index = 1;
    snap = writer.write(fr);
  }
  const io::Frame frame = io::read_snapshot(world.comm(), snap);
  if (written)
    written(frame);
  {
    auto again = Simulation::create(s, exec::Backend::Cpu, &world);
    again->restore(frame);
    check(*again, true, "N ranks -> N ranks");
  }
  {
    // As a run restarts: each rank reads a share of the fluid and the boundary (whose rows go on
    // to their owners), the rest whole.
    auto again = Simulation::create(s, exec::Backend::Cpu, &world);
    again->restore(io::read_snapshot_shares(world.comm(), snap, {"fluid", "boundary"}));
    check(*again, true, "N ranks -> N ranks, read in shares");
  }
  {
    auto alone = Simulation::create(s, exec::Backend::Cpu);
    alone->restore(frame);
    check(*alone, false, "N ranks -> 1 rank");
    // Shares of N ranks are not a one-rank run's frame (where the frame has fluid or walls).
    const io::Frame shares = io::read_snapshot_shares(world.comm(), snap, {"fluid", "boundary"});
    if (world.size() > 1 && !shares.shared_phases.empty()) {
      auto wrong = Simulation::create(s, exec::Backend::Cpu);
      EXPECT_THROW(wrong->restore(shares), Error);
    }
  }
  {
    auto split = Simulation::create(s, exec::Backend::Cpu, &world);
    split->restore(one_at_first);
    check(*split, true, "1 rank -> N ranks");
  }
}

} // namespace kf::test
