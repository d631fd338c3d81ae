#pragma once
// What a simulation's set-up holds at most on the CPU backend (its ledger: the allocations a GPU
// would hold), on one rank and on each rank of a split (MPI tests).
#include "comm/MpiContext.hpp"
#include "domain/Simulation.hpp"
#include "kernels/exec/Backend.hpp"

#include <mpi.h>

#include <algorithm>
#include <cstdio>
#include <vector>

namespace kf::test {

struct StartPeaks {
  double one = 0;          // bytes, the scene on one rank
  std::vector<double> all; // bytes, each rank's on mpi's ranks
  double largest() const { return *std::max_element(all.begin(), all.end()); }
};

/// Creates the scene's simulation on one rank, then split over mpi's ranks; prints the peaks on
/// rank 0.
inline StartPeaks start_peaks(const Scene& s, const comm::MpiContext& mpi) {
  const auto cpu = exec::Backend::Cpu;
  const auto peak_of = [&](const comm::MpiContext* over) {
    const std::size_t before = exec::held_bytes(cpu).now;
    exec::reset_peak_bytes(cpu);
    auto sim = Simulation::create(s, cpu, over);
    return double(exec::held_bytes(cpu).peak - before);
  };
  StartPeaks p;
  p.one = peak_of(nullptr);
  const double mine = peak_of(&mpi);
  p.all.resize(mpi.size());
  MPI_Allgather(&mine, 1, MPI_DOUBLE, p.all.data(), 1, MPI_DOUBLE, mpi.comm());
  if (mpi.rank() == 0) {
    std::printf("the backend's peak at the start: one rank %.0f kB; on %d ranks", p.one / 1e3,
                mpi.size());
    for (double b : p.all)
      std::printf(" %.0f", b / 1e3);
    std::printf(" kB (the largest %.2f of one rank's)\n", p.largest() / p.one);
  }
  return p;
}

} // namespace kf::test
