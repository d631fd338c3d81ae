// The samplers' time at set-up: a scene's fluid and boundary samples (every rank of a split job
// runs them three times: the first partition's box, its counts a block, its own samples), by
// the sieve's bounded boxes against a distance a lattice point (`SamplerWork::by_points`, the
// samplers before the sieve; the same samples, test_samplers).
//
//   bench_samplers [--scene scenes/dambreak.toml] [--particles 1e6,8e6] [--repeats 3]
//
// Prints, per size and way: lattice points, samples, boxes bounded, points tested alone, and
// the best of the repeats in seconds. One thread (the samplers are serial). docs/PERFORMANCE.md
// records the figures.
#include "BenchSupport.hpp"
#include "domain/Samplers.hpp"

#include <CLI/CLI.hpp>
#include <mpi.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <string>
#include <vector>

using namespace kf;
using Clock = std::chrono::steady_clock;

int main(int argc, char** argv) {
  MPI_Init(&argc, &argv);
  CLI::App app{"knitflow samplers benchmark"};
  std::string scene_path = std::string(KF_SOURCE_DIR) + "/scenes/dambreak.toml";
  std::vector<double> sizes{1e6, 8e6};
  int repeats = 3;
  app.add_option("--scene", scene_path, "scene file");
  app.add_option("--particles", sizes, "fluid particles (the spacing that gives about as many)")
      ->delimiter(',');
  app.add_option("--repeats", repeats, "timed passes of each way (the best is printed)")
      ->check(CLI::Range(1, 100));
  if (const auto rc = bench::parse_or_exit(app, argc, argv))
    return *rc;

  std::printf("knitflow bench_samplers: %s\n", scene_path.c_str());
  std::printf("%10s %6s %-10s %12s %10s %10s %10s %9s\n", "particles", "phase", "way", "points",
              "samples", "boxes", "tested", "best s");
  for (const double n : sizes) {
    const double dp = bench::spacing_for(scene_path, n);
    const Scene scene = load_scene(scene_path, {bench::spacing_override(dp)});
    const double depth = scene.support_radius();
    for (const bool by_points : {true, false}) {
      for (const char* phase : {"fluid", "walls"}) {
        double best = 1e300;
        SamplerWork work;
        std::size_t samples = 0;
        for (int r = 0; r < repeats; ++r) {
          work = SamplerWork{};
          work.by_points = by_points;
          samples = 0;
          const auto t0 = Clock::now();
          if (phase[0] == 'f')
            for_each_fluid_sample(
                scene, [&](const Vec3d&, const Vec3d&) { ++samples; }, &work);
          else
            for_each_boundary_sample(
                scene, dp, depth, [&](const Vec3d&, std::uint32_t, double) { ++samples; }, &work);
          best = std::min(best, std::chrono::duration<double>(Clock::now() - t0).count());
        }
        std::printf("%10.3g %6s %-10s %12llu %10zu %10llu %10llu %9.3f\n", n, phase,
                    by_points ? "by points" : "sieve", (unsigned long long)work.points, samples,
                    (unsigned long long)work.boxes, (unsigned long long)work.tested, best);
        std::fflush(stdout);
      }
    }
  }
  MPI_Finalize();
  return 0;
}
