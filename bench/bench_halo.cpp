// What a fluid halo costs on the host path (P5's communication model, jobs/studies/comm_model.py):
// under mpiexec -n R, each rank owns a block of a dam-break-like lattice of N particles a rank
// (the blocks shared out by METIS), chooses its ghosts (the rebuild: select_ghosts + the
// HaloExchange's size exchange) and refreshes them (pack, transfer, unpack) with the columns a
// step moves: x, v before the density pass and rho, P before the forces (32 B a ghost in float).
// Prints one CSV row per size: particles a rank, ghosts, bytes a refresh, and the times.
//   mpiexec -n 2 build/cpu/bench/bench_halo --particles 125000,1000000 --repeats 20
#include "comm/HaloExchange.hpp"
#include "comm/MpiContext.hpp"
#include "comm/Transport.hpp"
#include "core/Vec3.hpp"
#include "domain/Decomposition.hpp"
#include "domain/GhostSelection.hpp"

#include <CLI/CLI.hpp>
#include <mpi.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <vector>

using namespace kf;
using Clock = std::chrono::steady_clock;

namespace {

double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0 : v[v.size() / 2];
}

} // namespace

int main(int argc, char** argv) {
  MPI_Init(&argc, &argv);
  int rc = 0;
  {
    comm::MpiContext mpi;
    CLI::App app{"halo refresh cost on the host path"};
    std::vector<double> sizes{125000, 1000000};
    int repeats = 20;
    double support = 2.0, skin = 0.1;
    app.add_option("--particles", sizes, "fluid particles a rank")->delimiter(',');
    app.add_option("--repeats", repeats, "refreshes timed per size");
    app.add_option("--support", support, "support radius in spacings");
    app.add_option("--skin", skin, "\"verlet\" skin in support radii (0: none)");
    try {
      app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
      rc = app.exit(e);
      MPI_Finalize();
      return rc;
    }
    auto transport = comm::make_transport(mpi, comm::TransportKind::Mpi, comm::MemorySpace::Host);
    if (mpi.root())
      std::printf("ranks,particles_per_rank,ghosts_per_rank,peers,bytes_per_refresh,"
                  "select_ms,refresh_ms,pack_ms\n");
    for (double per_rank : sizes) {
      // A column 1 : 1 : 2 (x : y : z) of the whole job's particles at spacing 1.
      const double total = per_rank * mpi.size();
      const int nx = std::max(1, static_cast<int>(std::round(std::cbrt(total / 2)))), ny = nx,
                nz = 2 * nx;
      const double h = support, width = h * (1 + skin);
      const BlockGrid g({0, 0, 0}, {double(nx), double(ny), double(nz)}, 4 * h);
      std::vector<std::array<double, kPhases>> counts(g.count(), {0, 0, 0});
      auto at = [&](int i, int j, int k) { return Vec3d{i + 0.5, j + 0.5, k + 0.5}; };
      for (int k = 0; k < nz; ++k)
        for (int j = 0; j < ny; ++j)
          for (int i = 0; i < nx; ++i)
            counts[g.block_of(at(i, j, k))][0] += 1;
      const Decomposition d = Decomposition::partition(g, counts, PhaseCosts{}, mpi.size(), width);
      std::vector<Vec3d> x;
      for (int k = 0; k < nz; ++k)
        for (int j = 0; j < ny; ++j)
          for (int i = 0; i < nx; ++i)
            if (d.owner(at(i, j, k)) == mpi.rank())
              x.push_back(at(i, j, k));
      // The rebuild: ghosts chosen and their counts exchanged.
      mpi.barrier();
      const auto t0 = Clock::now();
      const GhostLists gl = select_ghosts(d, mpi.rank(), x, width);
      const double chosen_s = seconds_since(t0);
      comm::HaloExchange halo(*transport, gl.peers, gl.send);
      const double select_s = mpi.max(seconds_since(t0));
      if (mpi.root())
        std::fprintf(stderr, "rank 0: ghosts chosen in %.3f ms\n", 1e3 * chosen_s);
      // The columns a step refreshes, in float: x, v (12 B each), rho, P (4 B each).
      const std::size_t n = x.size(), ng = halo.received();
      std::vector<Vec3<float>> xf(n + ng), vf(n + ng);
      std::vector<float> rho(n + ng, 1000.f), p(n + ng, 0.f);
      for (std::size_t i = 0; i < n; ++i)
        xf[i] = vec_cast<float>(x[i]);
      const comm::Column cols[] = {{xf.data(), sizeof(Vec3<float>)},
                                   {vf.data(), sizeof(Vec3<float>)},
                                   {rho.data(), sizeof(float)},
                                   {p.data(), sizeof(float)}};
      std::vector<double> whole, packing;
      for (int r = 0; r < repeats; ++r) {
        mpi.barrier();
        const auto a = Clock::now();
        halo.start(cols, n);
        const double packed = seconds_since(a);
        const auto b = Clock::now();
        halo.finish();
        const double waited = seconds_since(b);
        whole.push_back(mpi.max(packed + waited));
        packing.push_back(packed); // the wait includes the unpack; reported whole below
      }
      const double bytes = mpi.sum(std::uint64_t(halo.last_bytes())) / double(mpi.size());
      const double ghosts = mpi.sum(std::uint64_t(ng)) / double(mpi.size());
      const double peers = mpi.sum(std::uint64_t(gl.peers.size())) / double(mpi.size());
      const double pack_ms = 1e3 * mpi.max(median(packing));
      if (mpi.root())
        std::printf("%d,%.0f,%.0f,%.1f,%.0f,%.3f,%.3f,%.3f\n", mpi.size(), total / mpi.size(),
                    ghosts, peers, bytes, 1e3 * select_s, 1e3 * median(whole), pack_ms);
    }
  }
  MPI_Finalize();
  return rc;
}
