// knitflow: the command. Parses arguments, then calls the library; every failure ends with a
// one-line reason and a non-zero exit code (2: bad input, 1: failure while running).
#include "RenderCommand.hpp"
#include "comm/MpiContext.hpp"
#include "core/Error.hpp"
#include "domain/CostModel.hpp"
#include "domain/PartitionPlan.hpp"
#include "domain/Runner.hpp"
#include "domain/Scene.hpp"
#include "domain/SceneCautions.hpp"
#include "domain/SceneSize.hpp"
#include "domain/Simulation.hpp"
#include "kernels/exec/Backend.hpp"

#include <CLI/CLI.hpp>
#include <algorithm>
#include <mpi.h>

#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <string>
#include <vector>

#if defined(_OPENMP)
#include <omp.h>
#endif

namespace {

struct Args {
  std::string scene;
  std::vector<std::string> overrides;
  std::string device = "auto";
  std::string restart;
  std::string output;
  bool quiet = false;
  bool profile = false;
  bool profile_device = false;
  int threads = 0;
  int ranks = 0; // plan: ranks to partition for (0: the job's)
};

void add_scene_options(CLI::App* cmd, Args& a) {
  cmd->add_option("scene", a.scene, "scene file (TOML)")->required();
  cmd->add_option("--set", a.overrides, "override a scene key: --set fluid.spacing=0.02")
      ->take_all();
}

kf::exec::Backend choose_backend(const std::string& device) {
  if (device == "cpu")
    return kf::exec::Backend::Cpu;
  if (device == "cuda") {
    if (!kf::exec::cuda_compiled())
      throw kf::InputError("--device cuda: this knitflow was built without CUDA (build it with "
                           "the 'cuda' preset, or run with --device cpu)");
    if (!kf::exec::cuda_available())
      throw kf::InputError("--device cuda: no CUDA device is visible (CUDA_VISIBLE_DEVICES=" +
                           std::string(std::getenv("CUDA_VISIBLE_DEVICES")
                                           ? std::getenv("CUDA_VISIBLE_DEVICES")
                                           : "unset") +
                           "; run with --device cpu)");
    return kf::exec::Backend::Cuda;
  }
  return kf::exec::cuda_available() ? kf::exec::Backend::Cuda : kf::exec::Backend::Cpu;
}

/// Refuses, before anything is sampled or allocated, a scene that cannot fit where it is to
/// run (domain/SceneSize): `plan` builds its counts on the host, `run` on its backend, each
/// rank its share (the ranks of one host share its memory; those of one GPU, the GPU's).
void check_scene_size(const kf::Scene& scene, kf::exec::Backend b, const kf::comm::MpiContext& mpi,
                      bool whole_on_host) {
  const kf::SceneSize z = kf::estimate_size(scene);
  if (whole_on_host) {
    kf::check_size(scene, z, kf::available_memory(kf::exec::Backend::Cpu), 1, mpi.local_size(),
                   "this machine's memory (MemAvailable)");
    return;
  }
  int sharing = mpi.local_size();
  if (b == kf::exec::Backend::Cuda) {
    const int devices = std::max(1, kf::exec::cuda_devices());
    sharing = (mpi.local_size() + devices - 1) / devices;
  }
  kf::check_size(scene, z, kf::available_memory(b), mpi.size(), sharing,
                 b == kf::exec::Backend::Cuda ? "the GPU's free memory"
                                              : "this machine's memory (MemAvailable)");
}

/// The split over `ranks`: blocks, ghost widths, and per rank what it owns, what it receives and
/// the bytes a step exchanges (domain/PartitionPlan).
void print_partition(const kf::Scene& scene, int ranks, const kf::PlanReport& r) {
  const kf::PartitionReport p = kf::Simulation::plan_split(scene, ranks);
  std::printf("ranks      %d: %d x %d x %d blocks of %.4g m (%d ghost widths), imbalance %.3f "
              "(slowest rank's cost over the mean)\n",
              ranks, p.blocks[0], p.blocks[1], p.blocks[2], p.block_edge,
              scene.parallel.block_cells, p.imbalance);
  std::printf("halo       ghost width fluid %.4g m (%.4g m beside walls), boundary %.4g m, knit "
              "%.4g m\n",
              p.widths.fluid, std::max(p.widths.walls, p.widths.fluid), p.widths.boundary,
              p.widths.knit);
  if (ranks == 1)
    return;
  std::printf("  rank %10s %10s %10s | %9s %9s %9s | %5s %10s %8s | %10s | %s\n", "fluid",
              "boundary", "knit", "ghosts:fl", "bnd", "knit", "peers", "recv/step", "cost",
              "memory", "grid cells");
  std::size_t total = 0;
  double most = 0, sum = 0;
  int largest = 0;
  for (int k = 0; k < ranks; ++k) {
    const kf::RankShare& s = p.rank[k];
    char grid[48] = "-";
    if (p.domain_cells > 0)
      std::snprintf(grid, sizeof grid, "%zu (%.0f%%)", s.grid_cells,
                    100.0 * double(s.grid_cells) / double(p.domain_cells));
    const double held = kf::rank_bytes(r, s, ranks);
    std::printf("  %4d %10zu %10zu %10zu | %9zu %9zu %9zu | %5d %10s %8.4g | %10s | %s\n", k,
                s.owned[0], s.owned[1], s.owned[2], s.ghosts[0], s.ghosts[1], s.ghosts[2],
                s.neighbours, kf::format_bytes(double(s.bytes_per_step)).c_str(), s.cost,
                kf::format_bytes(held).c_str(), grid);
    total += s.bytes_per_step;
    sum += held;
    if (held > most) {
      most = held;
      largest = k;
    }
  }
  std::printf(
      "memory     per rank on %d ranks: the most %s (rank %d), the mean %s (as the memory "
      "line's measure: the particles' and the knit's columns, the fluid's lists, the grids, the "
      "solids, the coupling)\n",
      ranks, kf::format_bytes(most).c_str(), largest, kf::format_bytes(sum / ranks).c_str());
  if (p.domain_cells > 0)
    std::printf("grids      each rank's a window of the domain's %zu cells (its blocks and the "
                "ghosts' reach)\n",
                p.domain_cells);
  std::printf("exchange   %s a step over all ranks (ghost refreshes between rebuilds)\n",
              kf::format_bytes(double(total)).c_str());
}

std::string human_seconds(double s) {
  char buf[32];
  if (s < 120)
    std::snprintf(buf, sizeof buf, "%.3g s", s);
  else if (s < 7200)
    std::snprintf(buf, sizeof buf, "%.3g min", s / 60);
  else
    std::snprintf(buf, sizeof buf, "%.3g h", s / 3600);
  return buf;
}

/// The run's steps and what they cost on each device of the model (domain/CostModel), and the
/// same for each quality preset.
void print_cost(const Args& a, const kf::Scene& scene, const kf::PlanReport& r) {
  // The run's dt: the initial one's limit, or the CFL condition at the fluid's fall speed where
  // that is smaller.
  if (r.run_dt < r.initial_dt)
    std::printf("steps      ~%.0f over the run (dt ~%.4g s: the CFL condition at the fluid's fall "
                "speed, %.3g m/s)\n",
                r.run_steps, r.run_dt, r.fall_speed);
  else
    std::printf("steps      ~%.0f over the run (dt ~%.4g s: %s)\n", r.run_steps, r.run_dt,
                r.dt_limit.c_str());
  std::string settings;
  for (const std::string& name : kf::cost_settings(scene))
    settings += (settings.empty() ? "" : ",") + name;
  std::string terms;
  for (const std::string& name : kf::knit_cost_terms(scene))
    terms += (terms.empty() ? "" : ",") + name;
  // The model's inputs in one line (jobs/studies/cost_model.py reads it).
  std::printf("model      fluid %zu, boundary %zu, knit %zu, support %g, steps %.0f, settings %s, "
              "substeps %d, knit terms %s, darcy substeps %.0f, frames %.0f\n",
              r.fluid, r.boundary, r.knit, scene.fluid.support, r.run_steps,
              settings.empty() ? "none" : settings.c_str(), r.knit ? scene.knit.substeps : 0,
              terms.empty() ? "none" : terms.c_str(), r.darcy_substeps, r.output_frames);
  const auto& model = kf::builtin_cost_model();
  for (const kf::DeviceCost& d : model) {
    const kf::CostEstimate e = kf::estimate_cost(d, scene, r);
    // The fit's worst miss over the runs like this scene: with a knit or without.
    const double off = r.knit && d.has_knit_terms()
                           ? d.worst_off
                           : (d.worst_off_fluid > 0 ? d.worst_off_fluid : d.worst_off);
    std::printf("cost       %-10s %.3g ms a step, %s in all (the model within %.0f%% of its "
                "studies'%s runs)%s\n",
                d.name.c_str(), 1e3 * e.step_s, human_seconds(e.total_s).c_str(), 100 * off,
                r.knit && d.has_knit_terms() ? "" : " fluid",
                r.knit && !d.has_knit_terms()
                    ? "; no knit run fitted this device: the knit not counted"
                    : "");
  }
  using Q = kf::Scene::Solver::Quality;
  for (Q q : {Q::Preview, Q::Production, Q::Reference}) {
    std::vector<std::string> with = a.overrides;
    with.push_back("solver.quality=\"" + kf::to_string(q) + "\"");
    const kf::Scene s = kf::load_scene(a.scene, with);
    const kf::PlanReport p = kf::Simulation::plan(s);
    std::printf("preset     %-10s fluid %zu:", kf::to_string(q).c_str(), p.fluid);
    for (const kf::DeviceCost& d : model)
      std::printf(" %s %s", d.name.c_str(),
                  human_seconds(kf::estimate_cost(d, s, p).total_s).c_str());
    std::printf("\n");
  }
}

int cmd_plan(const Args& a, const kf::comm::MpiContext& mpi) {
  const kf::Scene scene = kf::load_scene(a.scene, a.overrides);
  check_scene_size(scene, kf::exec::Backend::Cpu, mpi, true);
  const kf::PlanReport r = kf::Simulation::plan(scene);
  if (!mpi.root())
    return 0;
  std::string mods;
  for (auto m : scene.modules)
    mods += (mods.empty() ? "" : ", ") + kf::to_string(m);
  std::printf("scene      %s (%s)\n", scene.name.c_str(), scene.path.c_str());
  for (const std::string& c : kf::scene_cautions(scene))
    std::printf("caution    %s\n", c.c_str());
  std::printf("modules    %s\n", mods.c_str());
  std::printf("precision  %s\n", std::string(kf::to_string(scene.precision)).c_str());
  if (scene.solver.quality != kf::Scene::Solver::Quality::None) {
    const kf::QualityPreset q = kf::quality_preset(scene.solver.quality);
    std::printf("quality    %s: fluid spacing x %g (now %g m), speed of sound x %g (now %g m/s), "
                "cfl %g, density %s, lists %s\n",
                kf::to_string(scene.solver.quality).c_str(), q.spacing_scale, scene.fluid.spacing,
                q.sound_speed_scale, scene.fluid.speed_of_sound, scene.solver.cfl,
                scene.solver.density == kf::DensityModel::Continuity ? "continuity" : "summation",
                scene.solver.neighbour_list == kf::Scene::Solver::NeighbourLists::Verlet ? "verlet"
                : scene.solver.neighbour_list == kf::Scene::Solver::NeighbourLists::On   ? "on"
                                                                                         : "off");
    if (q.contact_at_scene_spacing && scene.has(kf::Module::Contact) &&
        !(scene.coupling.stiffness > 0))
      std::printf("quality    the knit-fluid contact as stiff as at the scene's spacing (%g m)\n",
                  scene.coupling.stiffness_spacing);
  }
  std::printf("particles  fluid %zu, boundary %zu, knit %zu (%zu springs, %zu volume cells)\n",
              r.fluid, r.boundary, r.knit, r.springs, r.volume_cells);
  if (scene.has(kf::Module::Fluid))
    std::printf("radius     h = %.6g m (kernel support; %.3g x spacing), grid %d x %d x %d cells\n",
                r.support_radius, scene.fluid.support, r.grid[0], r.grid[1], r.grid[2]);
  if (r.knit)
    std::printf(
        "knit       contact radius %.3g m against solids; self-collision %s\n", scene.knit.radius(),
        r.knit_self_radius > 0 ? ("R = " + std::to_string(r.knit_self_radius) + " m").c_str()
                               : "off");
  if (r.coupling_reach > 0) {
    std::printf("coupling   fluid-knit contact reach %.3g m, stiffness %.4g N/m", r.coupling_reach,
                r.coupling_stiffness);
    if (scene.has(kf::Module::Capillary))
      std::printf("; capillary phi %.3g, kappa %.3g m^2, sigma %.3g N/m", scene.capillary.porosity,
                  scene.capillary.permeability, scene.capillary.sigma);
    std::printf("\n");
  }
  for (const std::string& o : r.obstacles)
    std::printf("obstacle   %s\n", o.c_str());
  std::string lists;
  if (r.bytes_lists > 0) // their width grows with the density over a run: the start's
    lists = ", the fluid's lists " + kf::format_bytes(r.bytes_lists) +
            " (the start's: " + std::to_string(r.list_most) + " neighbours at most)";
  if (r.bytes_coupling > 0) // its lists' rows: one a fluid particle near the knit, at most
    lists += ", the coupling " + kf::format_bytes(r.bytes_coupling) +
             " (its lists' rows for up to " + std::to_string(r.coupling_near) +
             " fluid particles near the knit)";
  std::printf(
      "memory     %s per rank on %d rank(s) (fluid %s, boundary %s, knit %s, grids %s, "
      "solids %s%s)\n",
      kf::format_bytes(double(r.bytes_shared()) / mpi.size() + double(r.bytes_solids)).c_str(),
      mpi.size(), kf::format_bytes(r.bytes_fluid).c_str(),
      kf::format_bytes(r.bytes_boundary).c_str(), kf::format_bytes(r.bytes_knit).c_str(),
      kf::format_bytes(r.bytes_grid).c_str(), kf::format_bytes(r.bytes_solids).c_str(),
      lists.c_str());
  print_partition(scene, a.ranks > 0 ? a.ranks : mpi.size(), r);
  std::printf("dt         %.4g s initially (limited by %s)\n", r.initial_dt, r.dt_limit.c_str());
  print_cost(a, scene, r);
  std::printf("output     %s every %.4g s to t = %.4g s\n",
              scene.output.enabled ? scene.output.dir.c_str() : "(disabled)", scene.output.interval,
              scene.end_time);
  std::printf("stages     (one time step, in order)\n");
  int i = 0;
  for (const auto& [name, what] : r.stages)
    std::printf("  %2d. %-34s %s\n", ++i, name.c_str(), what.c_str());
  return 0;
}

int cmd_run(const Args& a, const kf::comm::MpiContext& mpi) {
  std::vector<std::string> overrides = a.overrides;
  if (!a.output.empty())
    overrides.push_back("output.dir=\"" + a.output + "\"");
  const kf::Scene scene = kf::load_scene(a.scene, overrides);
#if defined(_OPENMP)
  if (a.threads > 0)
    omp_set_num_threads(a.threads);
#endif
  kf::RunOptions opt;
  opt.backend = choose_backend(a.device);
  if (opt.backend == kf::exec::Backend::Cuda)
    kf::exec::cuda_select_device(mpi.local_rank());
  check_scene_size(scene, opt.backend, mpi, false);
  opt.restart = a.restart;
  opt.progress = !a.quiet;
  opt.profile = a.profile;
  opt.profile_device = a.profile_device;
  if (const char* f = std::getenv("KF_FAULT"))
    opt.fault = kf::parse_fault(f);
  if (mpi.root()) // also when quiet: a study's runs keep them in their logs
    for (const std::string& c : kf::scene_cautions(scene))
      std::cerr << "knitflow: caution: " << c << "\n";
  if (mpi.root() && !a.quiet)
    std::cerr << "knitflow: " << scene.name << " on " << kf::exec::describe(opt.backend) << ", "
              << mpi.size() << " rank(s), " << kf::to_string(scene.precision) << "\n";
  const kf::RunSummary s = kf::run_scene(scene, opt, mpi, std::cerr);
  if (mpi.root() && !a.quiet)
    std::cerr << kf::format_summary(s);
  return 0;
}

} // namespace

int main(int argc, char** argv) {
  MPI_Init(&argc, &argv);
  int rc = 0, ranks = 1;
  MPI_Comm_size(MPI_COMM_WORLD, &ranks);
  {
    kf::comm::MpiContext mpi;
    CLI::App app{"knitflow: knitted cloth and liquid, simulated with particles"};
    app.require_subcommand(1);
    Args a;
    auto* run = app.add_subcommand("run", "run a scene, writing snapshots");
    add_scene_options(run, a);
    run->add_option("--device", a.device, "cpu, cuda or auto (the GPU when present)")
        ->check(CLI::IsMember({"auto", "cpu", "cuda"}));
    run->add_option("--restart", a.restart,
                    "continue from this snapshot or checkpoint (frame_NNNNNN.h5), or 'latest': "
                    "the newest complete one in the output directory");
    run->add_option("--output", a.output, "output directory (overrides output.dir)");
    run->add_option("--threads", a.threads, "OpenMP threads for the CPU backend");
    run->add_flag("--quiet,-q", a.quiet, "no progress line or summary");
    run->add_flag("--profile", a.profile, "time every stage (synchronises the device)");
    run->add_flag("--profile-device", a.profile_device,
                  "time every stage on the device too, without synchronising: each stage's span "
                  "and the device's wait before it");
    auto* plan =
        app.add_subcommand("plan", "print stages, particle counts, memory and dt; run nothing");
    add_scene_options(plan, a);
    plan->add_option("--ranks", a.ranks, "partition for this many ranks (default: the job's)")
        ->check(CLI::PositiveNumber);
    kf::RenderArgs ra;
    auto* render = app.add_subcommand("render", "draw a run's snapshots as PNG pictures");
    render->add_option("run_dir", ra.run_dir, "the run's output directory (its frame_*.h5)")
        ->required();
    render->add_option("--frames", ra.frames, "A:B:S: frames A to B every S (default: all)");
    render->add_option("--out", ra.out, "where the pictures go (default: RUN_DIR/render)");
    render->add_option("--width", ra.width, "picture width in pixels")
        ->check(CLI::Range(16, 16384));
    render->add_option("--height", ra.height, "picture height in pixels")
        ->check(CLI::Range(16, 16384));
    render->add_option(
        "--scene", ra.scene,
        "obstacles and [render] from this scene file (default: the snapshot's copy)");
    render->add_option("--set", ra.overrides,
                       "override a scene key: --set render.eye=[0.1,-0.2,0.6] (with "
                       "render.target: a close-up)");
    render->add_flag("--boundary", ra.boundary, "draw the walls' particles too");
    render->add_flag("!--no-film", ra.film, "no MP4 (made with ffmpeg where it is installed)");
    render->add_option("--fps", ra.fps, "the film's frames a second")->check(CLI::Range(1, 240));
    render->add_flag("--quiet,-q", ra.quiet, "no progress lines");
    render
        ->add_option("--split", ra.split,
                     "frames (whole frames a rank), space (each frame in parts of space, "
                     "composited) or auto (space when fewer frames than ranks)")
        ->check(CLI::IsMember({"auto", "frames", "space"}));
    render
        ->add_option("--fluid", ra.fluid,
                     "surface (marching cubes over the particles) or spheres (the particles)")
        ->check(CLI::IsMember({"surface", "spheres"}));
    render
        ->add_option("--knit", ra.knit,
                     "yarns (tubes along the snapshot's yarns) or points (the knit's spheres)")
        ->check(CLI::IsMember({"yarns", "points"}));
    try {
      app.parse(argc, argv);
      if (render->parsed())
        kf::render_run(ra, mpi, std::cerr);
      else
        rc = run->parsed() ? cmd_run(a, mpi) : cmd_plan(a, mpi);
    } catch (const CLI::ParseError& e) {
      rc = app.exit(e);
      if (rc != 0)
        rc = 2;
    } catch (const kf::InputError& e) { // a bad scene, option or path
      if (mpi.root())
        std::cerr << "knitflow: error: " << e.what() << "\n";
      rc = 2;
    } catch (const std::exception& e) {
      // A failure while running may be one rank's alone: every rank says its own, named, before
      // the abort below ends the job (the others may be waiting in a collective).
      if (mpi.size() > 1)
        std::cerr << "knitflow: rank " << mpi.rank() << ": error: " << e.what() << "\n";
      else
        std::cerr << "knitflow: error: " << e.what() << "\n";
      std::cerr.flush();
      rc = 1;
    }
  }
  // Another rank may be waiting in a collective; alone, a plain exit says it without MPI's banner.
  if (rc == 1 && ranks > 1)
    MPI_Abort(MPI_COMM_WORLD, 1);
  MPI_Finalize();
  return rc;
}
