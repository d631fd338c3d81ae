// Mesh signed-distance sampling time: the 10,080-triangle torus of test_mesh_sdf (72 x 70 quads,
// R 0.3, r 0.12) sampled at the default grid (at most 64^3 nodes), repeated, per thread count.
//
//   bench_mesh_sdf [--repeats 5] [--threads 1,2] [--max-samples 262144]
//
// Prints the grid, then min and median seconds per thread count, and the machine's processor
// count. Timing goals live here, never in unit tests (test_mesh_sdf checks the same grid's
// size); docs/PERFORMANCE.md records the figures.
#include "BenchSupport.hpp"
#include "domain/MeshSdf.hpp"
#include "domain/MeshSolid.hpp"
#include "io/ObjReader.hpp"

// Header-only, no gtest: the same mesh generator the test uses, so both see one mesh.
#include "../tests/support/MeshReference.hpp"

#include <CLI/CLI.hpp>
#include <mpi.h>
#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <string>
#include <thread>
#include <vector>

using namespace kf;
using Clock = std::chrono::steady_clock;

int main(int argc, char** argv) {
  MPI_Init(&argc, &argv);
  CLI::App app{"knitflow mesh signed-distance sampling benchmark"};
  int repeats = 5;
  std::vector<int> threads{omp_get_max_threads()};
  std::size_t max_samples = SdfResolution{}.max_samples;
  app.add_option("--repeats", repeats, "timed samplings per thread count (after one warm-up)")
      ->check(CLI::Range(1, 1000));
  app.add_option("--threads", threads, "OpenMP thread counts")->delimiter(',');
  app.add_option("--max-samples", max_samples, "grid nodes at most (the scenes' default: 64^3)")
      ->check(CLI::Range(std::size_t(8), SdfResolution{}.max_samples));
  if (const auto rc = bench::parse_or_exit(app, argc, argv))
    return *rc;

  const std::string text = test::torus_obj({0, 0, 0}, 0.3, 0.12, 72, 70);
  const MeshSolid solid = make_mesh_solid(io::parse_obj(text, "torus.obj"), 1.0, {0, 0, 0});
  SdfResolution res;
  res.max_samples = max_samples;
  std::printf("knitflow bench_mesh_sdf: %zu triangles; machine: %u hardware threads "
              "(omp_get_num_procs %d)\n",
              solid.triangles.size(), std::thread::hardware_concurrency(), omp_get_num_procs());
  std::printf("%4s %8s %16s %10s %10s %10s\n", "thr", "repeats", "grid", "nodes", "min s",
              "median s");
  for (int t : threads) {
    omp_set_num_threads(t);
    SdfGrid g = sample_sdf(solid, res); // warm-up: page faults and thread start not timed
    std::vector<double> s;
    for (int k = 0; k < repeats; ++k) {
      const auto t0 = Clock::now();
      g = sample_sdf(solid, res);
      s.push_back(std::chrono::duration<double>(Clock::now() - t0).count());
    }
    std::sort(s.begin(), s.end());
    const double median =
        s.size() % 2 ? s[s.size() / 2] : 0.5 * (s[s.size() / 2 - 1] + s[s.size() / 2]);
    const std::string grid = std::to_string(g.dims[0]) + "x" + std::to_string(g.dims[1]) + "x" +
                             std::to_string(g.dims[2]);
    std::printf("%4d %8d %16s %10zu %10.3f %10.3f\n", t, repeats, grid.c_str(), g.values.size(),
                s.front(), median);
    std::fflush(stdout);
  }
  MPI_Finalize();
  return 0;
}
