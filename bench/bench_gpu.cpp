// P4 GPU benchmark: the figures P4 is judged by, as one table (a row per case), on one device.
//
//   bench_gpu [--device cuda|cpu] [--cases dambreak,column,pour,ratio,memory]
//             [--sizes 1e5,1e6,4e6,1.6e7] [--column-dp 0.0085,0.0035] [--work 4e8] [--steps N]
//             [--max-seconds 20] [--bandwidth-gbs 3000] [--fp32-tflops 67] [--gpu-mem-gib G]
//             [--lists off,on,verlet] [--column-start T] [--set KEY=VALUE]...
//             [--threads T] [--root DIR] [--csv FILE]
//
// Cases (rows):
//   dambreak  scenes/dambreak.toml refined to each --sizes fluid count (as bench_dambreak).
//   column    scenes/bench/dambreak_column.toml (DualSPHysics's 3D dam break with a column) at
//             each --column-dp, against DualSPHysics 5.4's ms/step on an H100.
//   pour      scenes/pour.toml (64k fluid + 50k knit), output off; goal 0.5 ms/step.
//   ratio     CPU backend (all host threads) vs CUDA on the 0.1M dam break and the pour.
//   memory    bytes per fluid particle (fluid-only dam break) and per knit point (drape.toml),
//             and the largest fluid-only dam break the GPU's memory holds.
// After the dambreak and column rows come "floor" rows for sph.density and sph.forces: bytes and
// flops per particle, the floor at --bandwidth-gbs and measured / floor.
//
// Each case: warm-up steps, then steps timed between device synchronisations, as many as
// --work particle-steps ask (at least 10; --steps fixes the count) but never more than
// --max-seconds of stepping; then a shorter pass with per-stage profiling (which synchronises
// after every stage, so it is kept out of ms/step) for the stage shares.
// Host-side only: the library launches every kernel.
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
#include <exception>
#include <filesystem>
#include <fstream>
#include <limits>
#include <memory>
#include <optional>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

using namespace kf;
using Clock = std::chrono::steady_clock;

namespace {

constexpr double kNone = std::numeric_limits<double>::quiet_NaN();

/// DualSPHysics 5.4 on an H100, ms/step of its CaseDambreak at dp 0.0085 (171k particles) and
/// 0.0035 (2.14M): the reference the column rows compare with.
std::optional<double> dualsphysics_ms(double dp) {
  if (std::abs(dp - 0.0085) < 1e-9)
    return 1.17;
  if (std::abs(dp - 0.0035) < 1e-9)
    return 8.3;
  return std::nullopt;
}

struct Options {
  exec::Backend device = exec::Backend::Cuda;
  double work = 4e8; // particle-steps timed per case
  long steps = 0;    // > 0: time exactly this many steps
  double max_seconds = 20;
  double bandwidth = 3000e9; // B/s
  double flops = 67e12;      // FP32 flop/s
};

/// What one timed run of a scene measured.
struct Timing {
  std::size_t fluid = 0, boundary = 0, knit = 0;
  long steps = 0;
  double seconds = 0;
  std::size_t memory = 0;
  std::optional<bench::PairCounts> pairs;
  std::vector<std::pair<std::string, double>> stage_seconds; // per step, profiled pass
  double profiled_step_seconds = 0;
  double sorts_per_step = kNone; // fluid sorts (list builds with "verlet" lists) in the timed steps

  double ms() const { return 1e3 * seconds / double(steps); }
  double stage(const std::string& name) const {
    for (const auto& [n, s] : stage_seconds)
      if (n == name)
        return s;
    return kNone;
  }
  /// Stages over 2% of the profiled step, as "name pct".
  std::string shares() const {
    std::ostringstream o;
    for (const auto& [n, s] : stage_seconds)
      if (s > 0.02 * profiled_step_seconds)
        o << (o.tellp() > 0 ? " " : "") << n << " " << std::lround(100 * s / profiled_step_seconds);
    return o.str();
  }
};

/// Times `scene` on `be`: `case_steps` steps (0: as many as --work asks), capped by
/// --max-seconds, unless --steps fixes the count. Particle-steps count fluid and knit alike.
/// advance_to > 0: steps (untimed) to that simulated time first.
Timing time_scene(const Scene& scene, exec::Backend be, const Options& opt, int warmup,
                  long case_steps, bool count_pairs, double advance_to = 0) {
  auto sim = Simulation::create(scene, be);
  while (sim->time() < advance_to)
    sim->step(advance_to);
  Timing t;
  const Diagnostics d = sim->diagnostics();
  t.fluid = d.fluid;
  t.boundary = d.boundary;
  t.knit = d.knit;
  if (count_pairs)
    t.pairs = bench::count_pairs(sim->frame(), scene.support_radius(),
                                 scene.precision == Precision::Double);
  for (int k = 0; k < warmup; ++k)
    sim->step(1e30);
  auto run = [&](long n) {
    exec::synchronize(be);
    const auto t0 = Clock::now();
    for (long k = 0; k < n; ++k)
      sim->step(1e30);
    exec::synchronize(be);
    return std::chrono::duration<double>(Clock::now() - t0).count();
  };
  // A short probe bounds the step count by --max-seconds.
  const double probe = std::max(run(2) / 2, 1e-7);
  const double particles = double(std::max<std::size_t>(1, t.fluid + t.knit));
  long steps = case_steps > 0 ? case_steps : std::max(10L, std::lround(opt.work / particles));
  long profiled = std::max(3L, std::min(steps / 4, long(0.25 * opt.max_seconds / probe)));
  steps = std::max(3L, std::min(steps, long(opt.max_seconds / probe)));
  if (opt.steps > 0) {
    steps = opt.steps;
    profiled = std::max(3L, steps / 4);
  }
  t.steps = steps;
  const auto sorts0 = sim->diagnostics().fluid_sorts;
  t.seconds = run(steps);
  if (t.fluid > 0)
    t.sorts_per_step = double(sim->diagnostics().fluid_sorts - sorts0) / double(steps);

  sim->set_profiling(true);
  std::vector<double> before;
  for (const auto& st : sim->pipeline().stages())
    before.push_back(st.seconds);
  t.profiled_step_seconds = run(profiled) / double(profiled);
  sim->set_profiling(false);
  const auto& stages = sim->pipeline().stages();
  for (std::size_t k = 0; k < stages.size(); ++k)
    t.stage_seconds.push_back({stages[k].name, (stages[k].seconds - before[k]) / double(profiled)});
  t.memory = sim->memory_bytes();
  return t;
}

/// One row of the table; NaN and empty fields print as "-".
struct Row {
  std::string kind, what, device;
  std::size_t fluid = 0, boundary = 0, knit = 0;
  long steps = 0;
  double ms = kNone, rate = kNone, neighbours = kNone, memory = kNone, bytes_per_particle = kNone;
  double ref_ms = kNone, speedup = kNone, goal_ms = kNone, floor_ms = kNone, over_floor = kNone;
  std::string stages, note;
};

Row row_from(const std::string& kind, const std::string& what, exec::Backend be, const Timing& t) {
  Row r;
  r.kind = kind;
  r.what = what;
  r.device = std::string(exec::to_string(be));
  r.fluid = t.fluid;
  r.boundary = t.boundary;
  r.knit = t.knit;
  r.steps = t.steps;
  r.ms = t.ms();
  r.rate = double(t.fluid + t.knit) * double(t.steps) / t.seconds;
  if (t.pairs) {
    r.neighbours = t.pairs->fluid + t.pairs->boundary;
    char split[64];
    std::snprintf(split, sizeof split, "nbr %.1f fluid + %.1f boundary", t.pairs->fluid,
                  t.pairs->boundary);
    r.note = split;
  }
  if (!std::isnan(t.sorts_per_step) && t.sorts_per_step < 1) {
    char sorts[64];
    if (t.sorts_per_step > 0)
      std::snprintf(sorts, sizeof sorts, "one sort per %.1f steps", 1 / t.sorts_per_step);
    else
      std::snprintf(sorts, sizeof sorts, "no sort in the timed steps");
    r.note += (r.note.empty() ? "" : "; ") + std::string(sorts);
  }
  r.memory = double(t.memory);
  if (t.fluid > 0)
    r.bytes_per_particle = double(t.memory) / double(t.fluid);
  r.stages = t.shares();
  return r;
}

std::string fmt(double v, const char* f) {
  if (std::isnan(v))
    return "-";
  char b[64];
  std::snprintf(b, sizeof b, f, v);
  return b;
}

std::string count(std::size_t n) {
  return n ? std::to_string(n) : "-";
}

void print_header() {
  std::printf("%-8s %-26s %-4s %9s %9s %6s %6s %9s %9s %5s %8s %6s %7s %7s %6s %8s %6s  %s\n",
              "case", "what", "dev", "fluid", "boundary", "knit", "steps", "ms/step", "p-st/s",
              "nbr", "MiB", "B/part", "ref ms", "ref/us", "goal", "floor ms", "x flr",
              "stages (% of step) / note");
}

void print_row(const Row& r) {
  std::string tail = r.stages;
  if (!r.note.empty())
    tail += (tail.empty() ? "" : "; ") + r.note;
  std::printf("%-8s %-26s %-4s %9s %9s %6s %6s %9s %9s %5s %8s %6s %7s %7s %6s %8s %6s  %s\n",
              r.kind.c_str(), r.what.c_str(), r.device.c_str(), count(r.fluid).c_str(),
              count(r.boundary).c_str(), count(r.knit).c_str(),
              r.steps ? std::to_string(r.steps).c_str() : "-", fmt(r.ms, "%.3f").c_str(),
              fmt(r.rate, "%.3g").c_str(), fmt(r.neighbours, "%.1f").c_str(),
              fmt(r.memory / (1 << 20), "%.1f").c_str(), fmt(r.bytes_per_particle, "%.0f").c_str(),
              fmt(r.ref_ms, "%.3f").c_str(), fmt(r.speedup, "%.2f").c_str(),
              fmt(r.goal_ms, "%.3f").c_str(), fmt(r.floor_ms, "%8.3g").c_str(),
              fmt(r.over_floor, "%.1f").c_str(), tail.c_str());
  std::fflush(stdout);
}

std::string csv_quote(const std::string& s) {
  std::string q = "\"";
  for (char c : s)
    q += c == '"' ? std::string("\"\"") : std::string(1, c);
  return q + "\"";
}

void write_csv(std::ofstream& out, const Row& r) {
  auto num = [](double v) {
    std::ostringstream o;
    o.precision(6);
    if (!std::isnan(v))
      o << v;
    return o.str();
  };
  out << r.kind << "," << csv_quote(r.what) << "," << r.device << "," << r.fluid << ","
      << r.boundary << "," << r.knit << "," << r.steps << "," << num(r.ms) << "," << num(r.rate)
      << "," << num(r.neighbours) << "," << num(r.memory) << "," << num(r.bytes_per_particle) << ","
      << num(r.ref_ms) << "," << num(r.speedup) << "," << num(r.goal_ms) << "," << num(r.floor_ms)
      << "," << num(r.over_floor) << "," << csv_quote(r.stages) << "," << csv_quote(r.note) << "\n";
}

/// "0.1M", "16M", "20k": a particle count as a label.
std::string size_label(double n) {
  char b[32];
  if (n >= 1e5)
    std::snprintf(b, sizeof b, "%gM", n / 1e6);
  else
    std::snprintf(b, sizeof b, "%gk", n / 1e3);
  return b;
}

/// The neighbour search the gather loops make, per interior fluid particle: candidates tested
/// in the cells around it and neighbours within the support. The cells come from `plan`'s grid
/// of a coarse copy of the scene (the cell edge is a fixed fraction of the support, so it does
/// not depend on dp): cells of edge h / span, (2 span + 1)^3 of them searched.
struct SearchModel {
  int span = 1;
  double candidates = 0; // per particle, a full lattice around it
  double neighbours = 0; // lattice points within the support, self included
};

SearchModel search_model(const std::string& path) {
  const Scene coarse = load_scene(path, {bench::spacing_override(bench::spacing_for(path, 2e4))});
  const PlanReport plan = Simulation::plan(coarse);
  const Vec3d extent = coarse.domain.max - coarse.domain.min;
  const double e[3] = {extent.x, extent.y, extent.z}, h = plan.support_radius;
  // The span whose grid (cells of h / span, padded by span cells, or by one cell in older
  // builds) has plan's dimensions; else the nearest ratio of h to the cell edge.
  auto dims_match = [&](int span, int pad) {
    for (int a = 0; a < 3; ++a)
      if (int(std::ceil(e[a] * span / h)) + 2 * pad != plan.grid[a])
        return false;
    return true;
  };
  SearchModel m;
  m.span = 0;
  for (int span = 1; span <= 4 && !m.span; ++span)
    if (dims_match(span, span) || dims_match(span, 1))
      m.span = span;
  if (!m.span) {
    double cell = 0;
    for (int a = 0; a < 3; ++a)
      cell = std::max(cell, e[a] / std::max(1, plan.grid[a] - 2));
    m.span = std::max(1, int(std::lround(h / cell)));
  }
  const double s = coarse.fluid.support; // support in units of dp
  m.candidates = std::pow(2.0 * m.span + 1, 3) * std::pow(s / m.span, 3);
  const int r = int(std::ceil(s));
  for (int i = -r; i <= r; ++i)
    for (int j = -r; j <= r; ++j)
      for (int k = -r; k <= r; ++k)
        if (i * i + j * j + k * k < s * s)
          m.neighbours += 1;
  return m;
}

/// Floor rows for the two heaviest stages of a timed fluid case. Flops: ~9 per candidate (the
/// distance test), ~15 per neighbour in density (kernel, mass), ~60 in forces (pressure, viscosity:
/// docs/PERFORMANCE.md P1). Bytes: the stage's fluid arrays (bench::kDensityBytesPerFluid,
/// kForcesBytesPerFluid) plus the cell tables around the fluid (rank, start, end: 12 B a cell,
/// fluid and boundary grids); neighbour gathers hit in cache and the boundary arrays are left
/// out (only their wetted part is read), so this is a lower bound. With neighbour lists
/// (list_reach: the lists' radius over the support; 0 without lists) each pass reads its list
/// from memory (4 B an entry) and tests the entries instead of the cells' candidates.
std::vector<Row> floor_rows(const std::string& what, exec::Backend be, const Timing& t,
                            const SearchModel& m, const Options& opt, double list_reach,
                            DensityModel density) {
  const double per_cell = m.candidates / std::pow(2.0 * m.span + 1, 3); // particles in a cell
  // Surface and wall particles have fewer fluid candidates; the measured neighbour count scales
  // the lattice's (fluid and boundary candidates together stay about a full lattice near walls).
  const double fill = t.pairs ? (t.pairs->fluid + t.pairs->boundary) / m.neighbours : 1.0;
  const double neighbours = m.neighbours * fill;
  const double entries = neighbours * list_reach * list_reach * list_reach;
  const double candidates = list_reach > 0 ? entries : m.candidates * fill;
  const double cell_bytes = list_reach > 0 ? 4 * entries : 2 * 12.0 / per_cell;
  struct StageModel {
    const char* name;
    double bytes, flops_per_neighbour;
    bool gathers = true; // false: a streaming pass (the continuity predictor), ~20 flop
  };
  // Continuity: the density stage predicts without neighbours; the forces pass adds the density
  // rate and diffusion, ~15 flop a neighbour.
  const bool cont = density == DensityModel::Continuity;
  const StageModel stages[2] = {
      cont ? StageModel{"sph.density", bench::kPredictBytesPerFluid, 0.0, false}
           : StageModel{"sph.density", bench::kDensityBytesPerFluid, 15.0},
      cont ? StageModel{"sph.forces", bench::kContinuityForcesBytesPerFluid, 75.0}
           : StageModel{"sph.forces", bench::kForcesBytesPerFluid, 60.0}};
  std::vector<Row> rows;
  for (const StageModel& sm : stages) {
    const double seconds = t.stage(sm.name);
    if (std::isnan(seconds))
      continue;
    const double bytes = sm.bytes + (sm.gathers ? cell_bytes : 0.0);
    const double flops = sm.gathers ? 9.0 * candidates + sm.flops_per_neighbour * neighbours : 20.0;
    const double n = double(t.fluid);
    Row r;
    r.kind = "floor";
    r.what = std::string(sm.name) + " " + what;
    r.device = std::string(exec::to_string(be));
    r.fluid = t.fluid;
    r.ms = 1e3 * seconds;
    r.rate = n / seconds;
    r.neighbours = neighbours;
    r.bytes_per_particle = bytes;
    r.floor_ms = 1e3 * bytes * n / opt.bandwidth;
    r.over_floor = r.ms / r.floor_ms;
    char note[256];
    std::snprintf(note, sizeof note,
                  "%.0f B + %.0f flop per particle (%.0f %s x 9 + %.0f neighbours x %.0f; "
                  "cells of h/%d); %.3g TFLOP/s achieved, compute floor %.3g ms at %.0f TFLOP/s",
                  bytes, flops, candidates, list_reach > 0 ? "list entries" : "candidates",
                  neighbours, sm.flops_per_neighbour, m.span, flops * n / seconds / 1e12,
                  1e3 * flops * n / opt.flops, opt.flops / 1e12);
    r.note = note;
    rows.push_back(r);
  }
  return rows;
}

/// GPU memory in bytes: --gpu-mem-gib, else the "N MiB" of describe(Cuda), else 80 GiB.
double gpu_memory(double gib_option) {
  if (gib_option > 0)
    return gib_option * double(1ull << 30);
  if (exec::cuda_available()) {
    std::smatch m;
    const std::string d = exec::describe(exec::Backend::Cuda);
    if (std::regex_search(d, m, std::regex("([0-9]+) MiB")))
      return std::stod(m[1]) * double(1 << 20);
  }
  return 80.0 * double(1ull << 30);
}

/// The fluid lists' radius over the support (0: no lists).
double list_reach(const Scene& s) {
  using L = Scene::Solver::NeighbourLists;
  return s.solver.neighbour_list == L::Off      ? 0.0
         : s.solver.neighbour_list == L::Verlet ? 1 + s.solver.neighbour_skin
                                                : 1.0;
}

/// " verlet" / " lists" after a row's label; nothing for the default (off).
std::string lists_label(const std::string& mode) {
  return mode == "off" ? "" : mode == "on" ? " lists" : " " + mode;
}

std::string join_args(int argc, char** argv) {
  std::string s;
  for (int i = 0; i < argc; ++i)
    s += (i ? " " : "") + std::string(argv[i]);
  return s;
}

} // namespace

int main(int argc, char** argv) {
  MPI_Init(&argc, &argv);
  CLI::App app{"knitflow P4 GPU benchmark: one table of dam break, column, pour, CPU/GPU ratio "
               "and memory figures"};
  std::string device = "cuda", csv;
  std::vector<std::string> cases{"dambreak", "column", "pour", "ratio", "memory"};
  std::vector<double> sizes{1e5, 1e6, 4e6, 16e6};
  std::vector<double> column_dp{0.0085, 0.0035};
  std::vector<std::string> lists{"off", "verlet"};
  double column_start = 0;
  std::vector<std::string> sets;
  double bandwidth_gbs = 3000, fp32_tflops = 67, gpu_mem_gib = 0;
  int threads = 0;
  std::string root;
  Options opt;
  app.add_option("--device", device, "cpu or cuda")->check(CLI::IsMember({"cpu", "cuda"}));
  app.add_option("--cases", cases, "comma list of dambreak,column,pour,ratio,memory")
      ->delimiter(',')
      ->check(CLI::IsMember({"dambreak", "column", "pour", "ratio", "memory"}));
  app.add_option("--sizes", sizes, "dam break fluid particle counts")->delimiter(',');
  app.add_option("--column-dp", column_dp, "dambreak_column.toml spacings [m]")->delimiter(',');
  app.add_option("--lists", lists,
                 "solver.neighbour_list modes of the dambreak and column rows (off,on,verlet)")
      ->delimiter(',')
      ->check(CLI::IsMember({"off", "on", "verlet"}));
  app.add_option("--set", sets, "KEY=VALUE scene override for every case (repeatable)");
  app.add_option("--column-start", column_start,
                 "simulated time [s] the column runs (untimed) before its timed steps; 0.3: "
                 "the surge reaches the column");
  app.add_option("--work", opt.work, "particle-steps timed per case (at least 10 steps)");
  app.add_option("--steps", opt.steps,
                 "time exactly this many steps in every case (default: by --work, capped by "
                 "--max-seconds; the pour 300, the CPU/GPU ratio's pour 30)");
  app.add_option("--max-seconds", opt.max_seconds, "cap on each case's timed stepping [s]");
  app.add_option("--bandwidth-gbs", bandwidth_gbs,
                 "memory bandwidth of the floors [GB/s]; default: H100 SXM, measured ~3000");
  app.add_option("--fp32-tflops", fp32_tflops, "FP32 peak of the compute floors; default H100 SXM");
  app.add_option(
      "--gpu-mem-gib", gpu_mem_gib,
      "GPU memory for the largest-fit estimate (default: from the CUDA device, else 80)");
  app.add_option("--threads", threads, "OpenMP threads of the CPU backend (default: all)");
  app.add_option("--root", root, "source tree whose scenes/ to run (default: the build's, else .)");
  app.add_option("--csv", csv, "also write the table as CSV");
  if (const auto rc = bench::parse_or_exit(app, argc, argv))
    return *rc;
  if (threads > 0)
    omp_set_num_threads(threads);
  opt.device = device == "cuda" ? exec::Backend::Cuda : exec::Backend::Cpu;
  opt.bandwidth = bandwidth_gbs * 1e9;
  opt.flops = fp32_tflops * 1e12;
  const std::set<std::string> want(cases.begin(), cases.end());
  const exec::Backend be = opt.device;
  const bool cuda = exec::cuda_available();
  if (be == exec::Backend::Cuda && !cuda) {
    std::fprintf(stderr, "bench_gpu: --device cuda: %s\n",
                 exec::cuda_compiled() ? "no CUDA device is visible"
                                       : "built without CUDA (use build/cuda, or --device cpu)");
    MPI_Finalize();
    return 2;
  }

  // The scenes of the source tree this was built from, else of the working directory (binaries
  // packed for another machine run in a copy of the tree at another path).
  if (root.empty())
    root = std::filesystem::exists(std::string(KF_SOURCE_DIR) + "/scenes/dambreak.toml")
               ? KF_SOURCE_DIR
               : ".";
  const std::string dambreak = root + "/scenes/dambreak.toml";
  const std::string column = root + "/scenes/bench/dambreak_column.toml";
  const std::string pour = root + "/scenes/pour.toml";
  const std::string drape = root + "/scenes/drape.toml";
  const std::string no_output = "output.enabled=false";
  // Every scene takes the --set overrides last.
  auto load = [&](const std::string& file, std::vector<std::string> overrides) {
    overrides.insert(overrides.end(), sets.begin(), sets.end());
    return load_scene(file, overrides);
  };

  std::printf("bench_gpu: %s\n", join_args(argc, argv).c_str());
  std::printf("device: %s\n", exec::describe(be).c_str());
  if (want.count("ratio") && be == exec::Backend::Cuda)
    std::printf("host:   %s\n", exec::describe(exec::Backend::Cpu).c_str());
  std::printf("floors at %.0f GB/s (--bandwidth-gbs) and %.0f FP32 TFLOP/s (--fp32-tflops)\n",
              bandwidth_gbs, fp32_tflops);
  print_header();

  std::ofstream out;
  if (!csv.empty()) {
    out.open(csv);
    out << "case,what,device,fluid,boundary,knit,steps,ms_per_step,particle_steps_per_s,"
           "neighbours,memory_bytes,bytes_per_particle,ref_ms,ref_over_ours,goal_ms,floor_ms,"
           "over_floor,stages,note\n";
  }
  std::vector<Row> floors; // printed after the timed rows
  auto emit = [&](const Row& r) {
    print_row(r);
    if (out)
      write_csv(out, r);
  };
  auto failed = [&](const std::string& kind, const std::string& what, exec::Backend b,
                    const std::exception& e) {
    Row r;
    r.kind = kind;
    r.what = what;
    r.device = std::string(exec::to_string(b));
    r.note = std::string("failed: ") + e.what();
    emit(r);
  };
  std::optional<std::pair<std::string, Timing>> largest_fluid_only; // for the memory rows

  // a) Fluid-only dam break, refined. Neighbours are counted on the host up to ~2M particles.
  if (want.count("dambreak")) {
    std::optional<SearchModel> model;
    for (const std::string& mode : lists)
      for (double n : sizes) {
        const std::string what = size_label(n) + lists_label(mode);
        try {
          if (!model)
            model = search_model(dambreak);
          const Scene s = load(dambreak, {bench::spacing_override(bench::spacing_for(dambreak, n)),
                                          no_output, "solver.neighbour_list=\"" + mode + "\""});
          const Timing t = time_scene(s, be, opt, 5, 0, n <= 2.1e6);
          Row r = row_from("dambreak", what, be, t);
          const double floor = bench::bytes_per_step(t.fluid, t.boundary, false) / opt.bandwidth;
          r.floor_ms = 1e3 * floor;
          r.over_floor = r.ms / r.floor_ms;
          if (t.fluid >= 3.5e6) // P4: 1e9 fluid particle-steps/s at 4M and above
            r.goal_ms = 1e3 * double(t.fluid) / 1e9;
          emit(r);
          for (const Row& f :
               floor_rows("dambreak " + what, be, t, *model, opt, list_reach(s), s.solver.density))
            floors.push_back(f);
          if (mode == "off" && (!largest_fluid_only || t.fluid > largest_fluid_only->second.fluid))
            largest_fluid_only = {"dam break " + what, t};
        } catch (const std::exception& e) {
          failed("dambreak", what, be, e);
        }
      }
  }

  // b) DualSPHysics's dam break with a column.
  if (want.count("column")) {
    std::optional<SearchModel> model;
    for (const std::string& mode : lists)
      for (double dp : column_dp) {
        char label[64];
        std::snprintf(label, sizeof label, "dp %g", dp);
        std::string what = label + lists_label(mode);
        if (column_start > 0) {
          std::snprintf(label, sizeof label, " from t=%g", column_start);
          what += label;
        }
        try {
          if (!model)
            model = search_model(column);
          const Scene s = load(column, {bench::spacing_override(dp), no_output,
                                        "solver.neighbour_list=\"" + mode + "\""});
          what += s.solver.density == DensityModel::Continuity ? " continuity" : " summation";
          const Timing t = time_scene(s, be, opt, 5, 0, column_start <= 0, column_start);
          Row r = row_from("column", what, be, t);
          r.floor_ms = 1e3 * bench::bytes_per_step(t.fluid, t.boundary, false) / opt.bandwidth;
          r.over_floor = r.ms / r.floor_ms;
          if (const auto ref = dualsphysics_ms(dp)) {
            r.ref_ms = *ref;
            r.speedup = *ref / r.ms;
            r.note += dp > 0.005 ? "; ref: DualSPHysics 5.4 on an H100, 171k particles"
                                 : "; ref: DualSPHysics 5.4 on an H100, 2.14M particles";
          }
          emit(r);
          for (const Row& f : floor_rows(std::string("column ") + what, be, t, *model, opt,
                                         list_reach(s), s.solver.density))
            floors.push_back(f);
        } catch (const std::exception& e) {
          failed("column", what, be, e);
        }
      }
  }

  // c) The pour at the paper's scale, output off.
  if (want.count("pour")) {
    for (const std::string& mode : lists) {
      const std::string what = "64k fluid + 50k knit" + lists_label(mode);
      try {
        const Timing t =
            time_scene(load(pour, {no_output, "solver.neighbour_list=\"" + mode + "\""}), be, opt,
                       10, 300, false);
        Row r = row_from("pour", what, be, t);
        r.bytes_per_particle = kNone; // two kinds of particle; the memory rows split them
        r.goal_ms = 0.5;
        emit(r);
      } catch (const std::exception& e) {
        failed("pour", what, be, e);
      }
    }
  }

  // d) CPU backend (all host threads) vs CUDA on the same scenes; ref ms = the CPU's.
  if (want.count("ratio")) {
    struct RatioCase {
      std::string what;
      Scene scene;
      int warmup;
      long steps;
    };
    std::vector<RatioCase> ratio_cases;
    try {
      ratio_cases.push_back(
          {"dambreak 0.1M",
           load(dambreak, {bench::spacing_override(bench::spacing_for(dambreak, 1e5)), no_output}),
           5, 0});
      ratio_cases.push_back({"pour", load(pour, {no_output}), 5, 30});
    } catch (const std::exception& e) {
      failed("ratio", "scenes", exec::Backend::Cpu, e);
    }
    // The CPU side gets half the time budget: it is the slow one and only sets the ratio.
    Options cpu_opt = opt;
    cpu_opt.max_seconds = 0.5 * opt.max_seconds;
    for (const RatioCase& c : ratio_cases) {
      std::optional<Timing> host;
      try {
        host = time_scene(c.scene, exec::Backend::Cpu, cpu_opt, c.warmup, c.steps, false);
        Row r = row_from("ratio", c.what, exec::Backend::Cpu, *host);
        r.note = std::to_string(omp_get_max_threads()) + " threads";
        emit(r);
      } catch (const std::exception& e) {
        failed("ratio", c.what, exec::Backend::Cpu, e);
      }
      if (!cuda) {
        Row r;
        r.kind = "ratio";
        r.what = c.what;
        r.device = "cuda";
        r.note = "no CUDA device: ratio not measured";
        emit(r);
        continue;
      }
      try {
        // The same steps as the CPU timed, so both average over the same stretch of the flow.
        const Timing t = time_scene(c.scene, exec::Backend::Cuda, opt, c.warmup,
                                    host ? host->steps : c.steps, false);
        Row r = row_from("ratio", c.what, exec::Backend::Cuda, t);
        if (host) {
          r.ref_ms = host->ms();
          r.speedup = r.ref_ms / r.ms;
          r.note = "ref = the CPU row above; ref/us = GPU speed-up";
        }
        emit(r);
      } catch (const std::exception& e) {
        failed("ratio", c.what, exec::Backend::Cuda, e);
      }
    }
  }

  // e) Bytes per fluid particle and per knit point; the largest dam break that fits.
  if (want.count("memory")) {
    try {
      if (!largest_fluid_only) {
        const double n =
            sizes.empty() ? 1e6 : std::min(4e6, *std::max_element(sizes.begin(), sizes.end()));
        const Scene s =
            load(dambreak, {bench::spacing_override(bench::spacing_for(dambreak, n)), no_output});
        Options quick = opt;
        quick.max_seconds = 1;
        largest_fluid_only = {"dam break " + size_label(n), time_scene(s, be, quick, 2, 3, false)};
      }
      const Timing& f = largest_fluid_only->second;
      Row r;
      r.kind = "memory";
      r.what = "fluid-only";
      r.device = std::string(exec::to_string(be));
      r.fluid = f.fluid;
      r.boundary = f.boundary;
      r.memory = double(f.memory);
      r.bytes_per_particle = r.memory / double(f.fluid);
      r.note = largest_fluid_only->first + "; bytes per fluid particle, its walls and grids "
                                           "included";
      emit(r);

      const double total = gpu_memory(gpu_mem_gib);
      const double usable = total - double(1ull << 30); // CUDA context, sort scratch
      Row fit;
      fit.kind = "memory";
      fit.what = "largest dam break";
      fit.device = "cuda";
      fit.fluid = std::size_t(usable / r.bytes_per_particle);
      fit.bytes_per_particle = r.bytes_per_particle;
      char note[160];
      std::snprintf(note, sizeof note,
                    "fits in %.1f GiB - 1 GiB (context, scratch) at the B/part above; walls grow "
                    "slower than the fluid, so a little more fits",
                    total / double(1ull << 30));
      fit.note = note;
      emit(fit);
    } catch (const std::exception& e) {
      failed("memory", "fluid-only", be, e);
    }
    try {
      Options quick = opt;
      quick.max_seconds = 1;
      const Timing k = time_scene(load(drape, {no_output}), be, quick, 2, 3, false);
      Row r;
      r.kind = "memory";
      r.what = "knit-only (drape)";
      r.device = std::string(exec::to_string(be));
      r.knit = k.knit;
      r.memory = double(k.memory);
      r.bytes_per_particle = r.memory / double(std::max<std::size_t>(1, k.knit));
      r.note = "bytes per knit point: springs, volume cells, self-contact grid included";
      emit(r);
    } catch (const std::exception& e) {
      failed("memory", "knit-only (drape)", be, e);
    }
  }

  // f) Floors of the two heaviest stages, for each dam break and column case.
  for (const Row& f : floors)
    emit(f);

  std::printf(
      "p-st/s: particle-steps per second (fluid + knit; floor rows: fluid particles per second "
      "through the stage). nbr: mean fluid + boundary neighbours within the support (floor "
      "rows: the model's). MiB: memory_bytes() (particle sets, grids, solids). B/part: its bytes "
      "per fluid particle (knit-only row: per knit point; floor rows: DRAM bytes per particle). "
      "ref ms: DualSPHysics 5.4 on an H100 (column), the CPU backend (ratio). ref/us: ref ms / "
      "our ms. goal: P4's 1e9 fluid particle-steps/s (dam break >= 4M), 0.5 ms (pour). floor ms: "
      "bytes the step (floor rows: the stage) must move / bandwidth; x flr: measured / floor. "
      "Stage shares from a separate profiled pass (synchronised after each stage).\n");
  MPI_Finalize();
  return 0;
}
