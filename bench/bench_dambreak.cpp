// Dam break throughput: fluid particle-steps per second of scenes/dambreak.toml refined to a target
// particle count, per thread count and backend, with a per-stage breakdown and the floors that
// bound it (memory: bytes moved / measured bandwidth; compute: pair evaluations).
//
//   bench_dambreak [--particles 50000,200000,1000000] [--threads 1,2] [--device cpu|cuda]
//                  [--precision float|double] [--work 2e7] [--csv FILE]
//
// Each case loads the scene, sets fluid.spacing so the column holds about N particles, runs
// 3 warm-up steps, then steps until `work` fluid particle-steps are done (at least 10 steps).
// Timing goals live here, never in unit tests; docs/PERFORMANCE.md records the figures.
#include "BenchSupport.hpp"
#include "domain/Scene.hpp"
#include "domain/Simulation.hpp"
#include "kernels/exec/Backend.hpp"

#include <CLI/CLI.hpp>
#include <mpi.h>
#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

using namespace kf;
using namespace kf::bench;
using Clock = std::chrono::steady_clock;

namespace {

/// STREAM triad a = b + s c over three arrays far larger than the caches, best of 5, in B/s
/// (24 bytes per element: two reads, one write; write-allocate traffic not counted, as STREAM).
double triad_bandwidth(int threads) {
  const std::size_t n = std::size_t(1) << 25; // 3 x 128 MiB in float
  std::vector<float> a(n), b(n, 1.0f), c(n, 2.0f);
  double best = 1e30;
  for (int rep = 0; rep < 5; ++rep) {
    const auto t0 = Clock::now();
#pragma omp parallel for num_threads(threads) schedule(static)
    for (std::size_t i = 0; i < n; ++i)
      a[i] = b[i] + 0.5f * c[i];
    best = std::min(best, std::chrono::duration<double>(Clock::now() - t0).count());
  }
  if (a[n / 2] != 2.0f)
    std::fprintf(stderr, "triad check failed\n");
  return 24.0 * double(n) / best;
}

struct Result {
  std::size_t fluid = 0, boundary = 0;
  int threads = 0;
  long steps = 0;
  double seconds = 0;
  double bandwidth = 0; // B/s, triad at this thread count
  double bytes_per_step = 0;
  PairCounts pairs;
  std::vector<std::pair<std::string, double>> stages; // seconds per stage over the timed steps
};

Result run_case(const std::string& scene_path, std::size_t target, int threads, exec::Backend be,
                const std::string& precision, double work) {
  Scene s = load_scene(scene_path,
                       {spacing_override(spacing_for(scene_path, double(target))),
                        "output.enabled=false", "simulation.precision=\"" + precision + "\""});
  omp_set_num_threads(threads);
  Result r;
  r.threads = threads;
  r.bandwidth = be == exec::Backend::Cpu ? triad_bandwidth(threads) : 0;
  auto sim = Simulation::create(s, be);
  const Diagnostics d0 = sim->diagnostics();
  r.fluid = d0.fluid;
  r.boundary = d0.boundary;
  r.pairs = count_pairs(sim->frame(), s.support_radius(), precision == "double");
  for (int k = 0; k < 3; ++k)
    sim->step(1e30);
  sim->set_profiling(true);
  std::vector<double> before;
  for (const auto& st : sim->pipeline().stages())
    before.push_back(st.seconds);
  const long steps = std::max(10L, long(work / double(r.fluid)));
  exec::synchronize(be);
  const auto t0 = Clock::now();
  for (long k = 0; k < steps; ++k)
    sim->step(1e30);
  exec::synchronize(be);
  r.seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  r.steps = steps;
  const auto& stages = sim->pipeline().stages();
  for (std::size_t k = 0; k < stages.size(); ++k)
    r.stages.push_back({stages[k].name, stages[k].seconds - before[k]});
  r.bytes_per_step = bytes_per_step(r.fluid, r.boundary, precision == "double");
  return r;
}

} // namespace

int main(int argc, char** argv) {
  MPI_Init(&argc, &argv);
  CLI::App app{"knitflow dam break throughput benchmark"};
  std::vector<std::size_t> particles{50000, 200000, 1000000};
  std::vector<int> threads{1, 2};
  std::string device = "cpu", precision = "float", csv;
  std::string scene = std::string(KF_SOURCE_DIR) + "/scenes/dambreak.toml";
  double work = 2e7;
  app.add_option("--particles", particles, "target fluid particle counts")->delimiter(',');
  app.add_option("--threads", threads, "OpenMP thread counts (CPU)")->delimiter(',');
  app.add_option("--device", device, "cpu or cuda")->check(CLI::IsMember({"cpu", "cuda"}));
  app.add_option("--precision", precision)->check(CLI::IsMember({"float", "double"}));
  app.add_option("--work", work, "fluid particle-steps timed per case");
  app.add_option("--scene", scene, "scene to refine (default scenes/dambreak.toml)");
  app.add_option("--csv", csv, "also write the table as CSV");
  if (const auto rc = bench::parse_or_exit(app, argc, argv))
    return *rc;
  const exec::Backend be = device == "cuda" ? exec::Backend::Cuda : exec::Backend::Cpu;
  if (be == exec::Backend::Cuda)
    threads = {omp_get_max_threads()};

  std::printf("knitflow bench_dambreak: %s, %s, scene %s\n", exec::describe(be).c_str(),
              precision.c_str(), scene.c_str());
  std::printf("%9s %9s %3s %6s %10s %11s %7s %7s %9s %9s  stages (%% of step)\n", "fluid",
              "boundary", "thr", "steps", "ms/step", "fl.p-st/s", "nbr f", "nbr b", "GB/s tri",
              "mem floor");
  std::ofstream out;
  if (!csv.empty()) {
    out.open(csv);
    out << "device,precision,fluid,boundary,threads,steps,ms_per_step,particle_steps_per_s,"
           "neighbours_fluid,neighbours_boundary,triad_GBps,bytes_per_step,floor_ms";
  }
  bool header_done = false;
  for (std::size_t n : particles)
    for (int t : threads) {
      const Result r = run_case(scene, n, t, be, precision, work);
      const double ms = 1e3 * r.seconds / double(r.steps);
      const double rate = double(r.fluid) * double(r.steps) / r.seconds;
      const double floor_ms = r.bandwidth > 0 ? 1e3 * r.bytes_per_step / r.bandwidth : 0;
      std::printf("%9zu %9zu %3d %6ld %10.3f %11.3e %7.1f %7.1f %9.1f %8.2fms ", r.fluid,
                  r.boundary, r.threads, r.steps, ms, rate, r.pairs.fluid, r.pairs.boundary,
                  r.bandwidth / 1e9, floor_ms);
      double total = 0;
      for (const auto& [name, sec] : r.stages)
        total += sec;
      for (const auto& [name, sec] : r.stages)
        if (sec > 0.02 * total)
          std::printf(" %s %.0f", name.c_str(), 100 * sec / r.seconds);
      std::printf("\n");
      std::fflush(stdout);
      if (out) {
        if (!header_done) {
          for (const auto& st : r.stages)
            out << ",s_" << st.first;
          out << "\n";
          header_done = true;
        }
        out << device << "," << precision << "," << r.fluid << "," << r.boundary << "," << r.threads
            << "," << r.steps << "," << ms << "," << rate << "," << r.pairs.fluid << ","
            << r.pairs.boundary << "," << r.bandwidth / 1e9 << "," << r.bytes_per_step << ","
            << floor_ms;
        for (const auto& st : r.stages)
          out << "," << st.second / double(r.steps);
        out << "\n";
      }
    }
  std::printf("fl.p-st/s: fluid particle-steps per second (the reference: SPlisHSPlasH 2.16 on "
              "2 cores, about 6e5). nbr: mean neighbours within h. mem floor: bytes the step "
              "must stream / triad bandwidth.\n");
  MPI_Finalize();
  return 0;
}
