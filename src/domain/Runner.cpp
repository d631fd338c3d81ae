#include "domain/Runner.hpp"
#include "domain/SceneSize.hpp"
#include "domain/StageParts.hpp"
#include "domain/Watchdog.hpp"

#include "core/Error.hpp"
#include "io/Checkpoints.hpp"
#include "io/Progress.hpp"
#include "io/SnapshotReader.hpp"
#include "io/SnapshotWriter.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <memory>
#include <optional>
#include <ostream>
#include <sstream>

#include <sys/resource.h>

namespace kf {

namespace {
/// What a restart reads in shares, each rank a part, sent on to the rows' owners: no rank's host
/// holds the whole fluid or boundary (SimulationT::restore). The knit, small, is read whole.
const std::vector<std::string> kSharedPhases{"fluid", "boundary"};
} // namespace

RunOptions::Fault parse_fault(const std::string& text) {
  RunOptions::Fault f;
  if (text.empty())
    return f;
  const auto a = text.find(':'), b = text.find(':', a == std::string::npos ? a : a + 1);
  try {
    if (a == std::string::npos || b == std::string::npos)
      throw std::invalid_argument("form");
    f.rank = std::stoi(text.substr(0, a));
    f.step = std::stoull(text.substr(a + 1, b - a - 1));
    f.kind = text.substr(b + 1);
  } catch (const std::exception&) {
    throw Error("KF_FAULT: expected rank:step:kind (kind error, instability, abort or segv), "
                "got '" +
                text + "'");
  }
  if (f.kind != "error" && f.kind != "instability" && f.kind != "abort" && f.kind != "segv")
    throw Error("KF_FAULT: expected the kind error, instability, abort or segv, got '" + f.kind +
                "'");
  return f;
}

namespace {

/// The last frame index written at or before a restart's state, for an output interval that may
/// differ from the one that wrote it: the snapshot's own index while its time falls in that
/// frame's interval, else the new interval's count of whole intervals (frame k at k * interval).
/// Taking the snapshot's index under another interval put the next output time behind the
/// restart's, and the first step ran backwards.
std::uint64_t restart_frame_index(const io::Frame& fr, double interval) {
  const double eps = 1e-9 * std::max(1.0, fr.time);
  const double at = double(fr.index) * interval;
  if (at <= fr.time + eps && fr.time < at + interval - eps)
    return fr.index;
  return static_cast<std::uint64_t>(std::floor((fr.time + eps) / interval));
}

void inject(const RunOptions::Fault& f, int rank, std::uint64_t steps) {
  // An instability is the job's (every rank finds it, from reduced bounds or readings): the
  // injected one fires on every rank, named by the rank given.
  if ((f.kind != "instability" && f.rank != rank) || steps != f.step)
    return;
  if (f.kind == "error")
    throw Error("injected fault (KF_FAULT) on rank " + std::to_string(rank) + " after step " +
                std::to_string(steps));
  if (f.kind == "instability") { // once a process: a rollback's second pass goes through
    static bool fired = false;
    if (fired)
      return;
    fired = true;
    throw InstabilityError("injected instability (KF_FAULT) on rank " + std::to_string(f.rank) +
                           " after step " + std::to_string(steps));
  }
  std::fprintf(stderr, "knitflow: rank %d: raising %s after step %llu (KF_FAULT)\n", rank,
               f.kind == "abort" ? "SIGABRT" : "SIGSEGV", static_cast<unsigned long long>(steps));
  std::fflush(stderr);
  std::raise(f.kind == "abort" ? SIGABRT : SIGSEGV);
}

/// --restart latest: the newest complete state in the scene's output directory, found by rank 0
/// and told to the others (one answer for the whole job).
std::string latest_state(const Scene& scene, const comm::MpiContext& mpi) {
  std::string path, error;
  if (mpi.root()) {
    try {
      path = io::latest_state(scene.output.dir);
    } catch (const InputError& e) {
      error = e.what();
    }
  }
  int sizes[2] = {int(path.size()), int(error.size())};
  MPI_Bcast(sizes, 2, MPI_INT, 0, mpi.comm());
  path.resize(std::size_t(sizes[0]));
  error.resize(std::size_t(sizes[1]));
  MPI_Bcast(path.data(), sizes[0], MPI_CHAR, 0, mpi.comm());
  MPI_Bcast(error.data(), sizes[1], MPI_CHAR, 0, mpi.comm());
  if (!error.empty())
    throw InputError(error);
  return path;
}

} // namespace

RunSummary run_scene(const Scene& scene_in, const RunOptions& opt, const comm::MpiContext& mpi,
                     std::ostream& log) {
  Scene scene = scene_in; // a rollback makes its steps smaller
  const auto profiled = [&opt](Simulation& s) {
    s.set_profiling(opt.profile);
    if (opt.profile_device)
      s.profile_on_device();
  };
  exec::reset_peak_bytes(opt.backend); // the summary's memory line: this run's most
  auto sim = Simulation::create(scene, opt.backend, &mpi);
  profiled(*sim);
  std::uint64_t frame_index = 0;
  if (!opt.restart.empty()) {
    const std::string from = opt.restart == "latest" ? latest_state(scene, mpi) : opt.restart;
    io::Frame fr = io::read_snapshot_shares(mpi.comm(), from, kSharedPhases);
    sim->restore(fr);
    frame_index = restart_frame_index(fr, scene.output.interval);
  }
  const double end = opt.stop_time >= 0 ? std::min(opt.stop_time, scene.end_time) : scene.end_time;
  const double interval = scene.output.interval;
  const bool output = scene.output.enabled;

  // The writer is made only now: a scene or restart that fails above has written nothing.
  std::unique_ptr<io::SnapshotWriter> writer;
  RunSummary sum;
  auto write_frame = [&](std::uint64_t index) {
    io::Frame fr = sim->frame();
    fr.index = index;
    sum.last_snapshot = writer->write(fr);
    ++sum.frames;
  };
  if (output) {
    writer = std::make_unique<io::SnapshotWriter>(mpi.comm(), scene.output.dir);
    if (opt.restart.empty())
      write_frame(0);
  }
  // Checkpoints: the whole state, on their own cadence, in the output directory.
  const auto& out = scene.output;
  std::unique_ptr<io::CheckpointWriter> checkpoints;
  if (output && (out.checkpoint_steps > 0 || out.checkpoint_seconds > 0))
    checkpoints = std::make_unique<io::CheckpointWriter>(
        mpi.comm(), scene.output.dir + "/checkpoints", static_cast<int>(out.checkpoint_keep));
  using Clock = std::chrono::steady_clock;
  auto last_checkpoint = Clock::now();
  auto checkpoint_due = [&] {
    if (out.checkpoint_steps > 0 &&
        sim->steps() % static_cast<std::uint64_t>(out.checkpoint_steps) == 0)
      return true;
    if (!(out.checkpoint_seconds > 0))
      return false;
    // Every rank must agree: rank 0's clock decides, read every 16 steps on N ranks.
    if (mpi.size() > 1 && sim->steps() % 16 != 0)
      return false;
    int due = std::chrono::duration<double>(Clock::now() - last_checkpoint).count() >=
              out.checkpoint_seconds;
    if (mpi.size() > 1)
      MPI_Bcast(&due, 1, MPI_INT, 0, mpi.comm());
    return due != 0;
  };

  io::Progress progress(log, end, opt.progress_interval_s, opt.progress && mpi.root());
  const std::uint64_t start_steps = sim->steps();
  // The split's seconds count from here: the set-up's distribution (and NCCL's first
  // connections) are not a step's.
  const Simulation::RankReport split0 = sim->rank_report();
  const auto since_start = [&split0](Simulation::RankReport r) {
    r.exchange_seconds -= split0.exchange_seconds;
    r.migration_seconds -= split0.migration_seconds;
    r.refresh_seconds -= split0.refresh_seconds;
    r.rebalance_seconds -= split0.rebalance_seconds;
    r.packing_seconds -= split0.packing_seconds;
    r.reduction_seconds -= split0.reduction_seconds;
    return r;
  };
  // Moving particles (fluid + knit): boundary particles only follow their solids.
  const Diagnostics d0 = sim->diagnostics();
  const std::uint64_t particles = d0.fluid + d0.knit;
  double next_out = (frame_index + 1) * interval;
  const double eps = 1e-12 * std::max(1.0, end);
  // The watchdog (domain/Watchdog): on a trigger, a diagnostic snapshot, then either the end
  // of the run with the report, or (on_instability = "rollback") the last checkpoint again with
  // cfl and dt_max halved and twice the knit's substeps.
  const bool watching = scene.solver.watchdog_steps > 0;
  std::optional<Watchdog> dog;
  if (watching)
    dog.emplace(scene, sim->watch(), stored_energy(d0), sim->time());
  long rollbacks = 0;
  auto trouble = [&](const std::string& why) {
    std::string diagnostic;
    if (output) {
      try {
        io::Frame fr = sim->frame();
        fr.index = frame_index;
        diagnostic = io::publish_snapshot(
            mpi.comm(),
            scene.output.dir + "/diagnostic_step_" + std::to_string(sim->steps()) + ".h5", fr);
      } catch (const Error&) { // the report matters more than its snapshot
      }
    }
    const std::string where =
        "; diagnostic snapshot: " + (diagnostic.empty() ? std::string("none") : diagnostic);
    if (scene.solver.on_instability == Scene::Solver::OnInstability::Rollback &&
        rollbacks < scene.solver.rollback_retries && !sum.last_checkpoint.empty()) {
      ++rollbacks;
      scene.solver.cfl *= 0.5;
      scene.solver.dt_max *= 0.5;
      scene.knit.substeps *= 2;
      if (mpi.root())
        log << "knitflow: " << why << where << "; rollback " << rollbacks << " of "
            << scene.solver.rollback_retries << " to " << sum.last_checkpoint << " with cfl "
            << scene.solver.cfl << ", dt_max " << scene.solver.dt_max << " s, knit substeps "
            << scene.knit.substeps << "\n";
      sim = Simulation::create(scene, opt.backend, &mpi);
      profiled(*sim);
      io::Frame fr = io::read_snapshot_shares(mpi.comm(), sum.last_checkpoint, kSharedPhases);
      sim->restore(fr);
      frame_index = restart_frame_index(fr, interval);
      next_out = (frame_index + 1) * interval;
      if (watching) // the energy's bound from the state it goes back to
        dog.emplace(scene, sim->watch(), stored_energy(sim->diagnostics()), sim->time());
      ++sum.rollbacks;
      return;
    }
    throw InstabilityError(why + where);
  };
  double last_dt = 0; // the last line shows the last step's size
  try {
    while (sim->time() < end - eps) {
      if (scene.solver.max_steps > 0 &&
          sim->steps() >= static_cast<std::uint64_t>(scene.solver.max_steps))
        break;
      const double t_limit = std::min(next_out, end);
      double dt = 0;
      try {
        dt = sim->step(t_limit);
        inject(opt.fault, mpi.rank(), sim->steps());
      } catch (const InstabilityError& e) {
        trouble(e.what());
        continue;
      }
      if (watching && sim->steps() % static_cast<std::uint64_t>(scene.solver.watchdog_steps) == 0) {
        const Watchdog::Trip trip = dog->check(sim->watch());
        if (!trip.why.empty()) {
          std::ostringstream at;
          at << "watchdog at step " << sim->steps() << ", t = " << sim->time()
             << " s (between steps): " << trip.why;
          if (trip.worst)
            if (const std::string w = sim->describe_worst(*trip.worst); !w.empty())
              at << "; worst " << w;
          trouble(at.str());
          continue;
        }
      }
      if (const auto r = since_start(sim->rank_report()); r.ranks > 1) {
        char note[128], imbalance[16] = "-"; // "-": not measured yet (the first check's)
        if (r.imbalance > 0)
          std::snprintf(imbalance, sizeof imbalance, "%.3f", r.imbalance);
        std::snprintf(note, sizeof note, "%d ranks, imbalance %s, exchanges %.1f%% of the step",
                      r.ranks, imbalance,
                      100 * r.exchange_seconds / std::max(1e-9, progress.wall_seconds()));
        progress.set_note(note);
      }
      progress.update(sim->steps(), sim->time(), dt, particles);
      last_dt = dt;
      if (sim->time() >= next_out - eps) {
        ++frame_index;
        if (output)
          write_frame(frame_index);
        next_out = (frame_index + 1) * interval;
      }
      if (checkpoints && checkpoint_due()) {
        io::Frame fr = sim->frame();
        fr.index = frame_index; // the last frame written: a restart continues its cadence
        sum.last_checkpoint = checkpoints->write(fr, sim->steps());
        ++sum.checkpoints;
        last_checkpoint = Clock::now();
      }
    }
  } catch (const InstabilityError& e) {
    progress.finish();
    throw InstabilityError(
        std::string(e.what()) +
        (sum.last_snapshot.empty() ? "; no snapshot was written"
                                   : "; last good snapshot: " + sum.last_snapshot) +
        (sum.last_checkpoint.empty() ? std::string()
                                     : ", last checkpoint: " + sum.last_checkpoint));
  }
  progress.update(sim->steps(), sim->time(), last_dt, 0, true);
  progress.finish();

  sum.steps = sim->steps() - start_steps;
  sum.sim_time = sim->time();
  sum.wall_seconds = progress.wall_seconds();
  sum.particle_steps_per_s =
      sum.wall_seconds > 0 ? double(sum.steps) * double(particles) / sum.wall_seconds : 0;
  sum.diagnostics = sim->diagnostics();
  if (opt.profile_device)
    sim->collect_device_profile();
  sum.split = since_start(sim->rank_report());
  for (const auto& s : sim->pipeline().stages()) {
    Pipeline::Stage copy = s;
    copy.run = nullptr; // the summary outlives the simulation its functions capture
    sum.stages.push_back(std::move(copy));
  }
  // Each stage's largest time over the ranks, on rank 0 (every rank runs the same stages).
  const auto slowest = [&](double Pipeline::Stage::*field) {
    std::vector<double> mine, most(sum.stages.size(), 0.0);
    for (const auto& s : sum.stages)
      mine.push_back(s.*field);
    MPI_Reduce(mine.data(), most.data(), static_cast<int>(mine.size()), MPI_DOUBLE, MPI_MAX, 0,
               mpi.comm());
    return most;
  };
  if (opt.profile_device && mpi.size() > 1) {
    sum.device_seconds_slowest = slowest(&Pipeline::Stage::device_seconds);
    MPI_Reduce(sum.split.refresh_pass_device.data(), sum.refresh_pass_slowest.data(),
               static_cast<int>(sum.refresh_pass_slowest.size()), MPI_DOUBLE, MPI_MAX, 0,
               mpi.comm());
  }
  if (opt.profile && mpi.size() > 1)
    sum.stage_seconds_slowest = slowest(&Pipeline::Stage::seconds);
  { // The most the backend held at once on a rank: the largest over the ranks, and their mean.
    const double peak = double(exec::held_bytes(opt.backend).peak);
    double most = peak, total = peak;
    MPI_Reduce(&peak, &most, 1, MPI_DOUBLE, MPI_MAX, 0, mpi.comm());
    MPI_Reduce(&peak, &total, 1, MPI_DOUBLE, MPI_SUM, 0, mpi.comm());
    sum.peak_bytes = {most, total / mpi.size()};
    rusage use{};
    getrusage(RUSAGE_SELF, &use);
    const double host = double(use.ru_maxrss) * 1024.0; // kilobytes on Linux
    double host_most = host, host_total = host;
    MPI_Reduce(&host, &host_most, 1, MPI_DOUBLE, MPI_MAX, 0, mpi.comm());
    MPI_Reduce(&host, &host_total, 1, MPI_DOUBLE, MPI_SUM, 0, mpi.comm());
    sum.host_peak_bytes = {host_most, host_total / mpi.size()};
    sum.backend = opt.backend;
    if (opt.profile)
      sum.peak_by_label = exec::peak_by_label(opt.backend);
  }
  if (mpi.size() > 1 && sum.split.domain_cells > 0) {
    const double share = double(sum.split.grid_cells) / double(sum.split.domain_cells);
    double lo = share, hi = share, total = share;
    MPI_Reduce(&share, &lo, 1, MPI_DOUBLE, MPI_MIN, 0, mpi.comm());
    MPI_Reduce(&share, &hi, 1, MPI_DOUBLE, MPI_MAX, 0, mpi.comm());
    MPI_Reduce(&share, &total, 1, MPI_DOUBLE, MPI_SUM, 0, mpi.comm());
    sum.grid_shares = {lo, total / mpi.size(), hi};
  }
  return sum;
}

namespace {

/// The profiled run's peak by buffer: the largest, then the rest in one line.
void print_peak_by_label(std::ostream& o, const RunSummary& s) {
  const auto& by = s.peak_by_label;
  if (by.empty())
    return;
  double total = 0;
  for (const auto& l : by)
    total += double(l.bytes);
  o << "memory at the peak by buffer" << (s.split.ranks > 1 ? " (rank 0)" : "") << ":\n";
  constexpr std::size_t kShown = 12;
  char buf[160];
  double rest = 0;
  for (std::size_t k = 0; k < by.size(); ++k) {
    if (k >= kShown) {
      rest += double(by[k].bytes);
      continue;
    }
    std::snprintf(buf, sizeof buf, "  %-32s %10s %6.1f%%\n", by[k].label.c_str(),
                  format_bytes(double(by[k].bytes)).c_str(), 100 * double(by[k].bytes) / total);
    o << buf;
  }
  if (rest > 0) {
    const std::string others = std::to_string(by.size() - kShown) + " others";
    std::snprintf(buf, sizeof buf, "  %-32s %10s %6.1f%%\n", others.c_str(),
                  format_bytes(rest).c_str(), 100 * rest / total);
    o << buf;
  }
}

} // namespace

std::string format_summary(const RunSummary& s) {
  std::ostringstream o;
  char buf[256];
  std::snprintf(
      buf, sizeof buf,
      "done: %llu steps to t = %.6g s in %.2f s wall, %.3e particle-steps/s (fluid + knit)\n",
      static_cast<unsigned long long>(s.steps), s.sim_time, s.wall_seconds, s.particle_steps_per_s);
  o << buf;
  const auto& d = s.diagnostics;
  if (d.fluid || d.boundary || !d.knit) {
    std::snprintf(
        buf, sizeof buf,
        "particles: fluid %zu, boundary %zu | max speed %.4g m/s | density error max "
        "%.3g%%, mean %.3g%% | closest approach to a solid %.3g m | guard corrections %llu\n",
        d.fluid, d.boundary, d.max_speed, 100 * d.max_density_error, 100 * d.mean_density_error,
        d.min_rigid_distance, static_cast<unsigned long long>(d.guard_corrections));
    o << buf;
    if (d.list_ends_far || d.list_ends_sheared) {
      std::snprintf(buf, sizeof buf,
                    "neighbour lists: %llu sorts, %llu after a particle moved over %.3g m, %llu "
                    "after pairs may have closed in by over the skin\n",
                    static_cast<unsigned long long>(d.fluid_sorts),
                    static_cast<unsigned long long>(d.list_ends_far), d.list_skin,
                    static_cast<unsigned long long>(d.list_ends_sheared));
      o << buf;
    }
    if (d.imbalance > 0) {
      std::snprintf(buf, sizeof buf,
                    "ranks: compute imbalance %.3f at the last check (its phases' slowest ranks "
                    "summed %.3f",
                    d.imbalance, d.phase_imbalance);
      o << buf;
      // Each timed phase's own spread: which phase's work is off.
      for (int p = 0; p < kPhases; ++p)
        if (d.phase_spread[p] > 0) {
          std::snprintf(buf, sizeof buf, "; %s %.3f", phase_name(static_cast<Phase>(p)),
                        d.phase_spread[p]);
          o << buf;
        }
      std::snprintf(buf, sizeof buf, "), %llu re-partition(s)",
                    static_cast<unsigned long long>(d.repartitions));
      o << buf;
      if (d.repartitions > 0) {
        std::snprintf(buf, sizeof buf, " (the last took %.3g s, METIS %.3g s of it)",
                      d.repartition_seconds, d.partition_seconds);
        o << buf;
      }
      if (d.pair_weight > 0) {
        std::snprintf(buf, sizeof buf, ", a coupling pair weighed as %.3g knit points",
                      d.pair_weight);
        o << buf;
      }
      if (d.declined_repartitions > 0) {
        std::snprintf(buf, sizeof buf,
                      ", %llu declined (the imbalance lost less than a re-partition costs)",
                      static_cast<unsigned long long>(d.declined_repartitions));
        o << buf;
      }
      if (d.balanced_declines > 0) {
        std::snprintf(buf, sizeof buf,
                      ", %llu declined (the particles balanced already: within %.3f by their "
                      "counts)",
                      static_cast<unsigned long long>(d.balanced_declines), d.declined_counted);
        o << buf;
      }
      o << "\n";
    }
    if (d.outflow_particles) {
      std::snprintf(buf, sizeof buf, "outflow: %llu fluid particles (%.4g kg) left the domain\n",
                    static_cast<unsigned long long>(d.outflow_particles), d.outflow_mass);
      o << buf;
    }
  }
  if (s.peak_bytes[0] > 0) {
    std::snprintf(buf, sizeof buf, "memory: the %s backend held at most %s at once",
                  std::string(exec::to_string(s.backend)).c_str(),
                  format_bytes(s.peak_bytes[0]).c_str());
    o << buf;
    if (s.split.ranks > 1)
      o << " on a rank (the mean rank " << format_bytes(s.peak_bytes[1]) << ")";
    if (s.host_peak_bytes[0] > 0) {
      o << "; the host's resident peak " << format_bytes(s.host_peak_bytes[0]);
      if (s.split.ranks > 1)
        o << " on a rank (the mean rank " << format_bytes(s.host_peak_bytes[1]) << ")";
    }
    o << "\n";
    print_peak_by_label(o, s);
  }
  if (const auto& r = s.split; r.ranks > 1) {
    const double knit = std::max(0.0, r.exchange_seconds - r.migration_seconds - r.refresh_seconds -
                                          r.rebalance_seconds - r.reduction_seconds);
    std::snprintf(buf, sizeof buf,
                  "split (rank 0 of %d, %s): exchanges %.3f s, %.1f%% of the wall: fluid "
                  "migration and ghosts %.3f s, ghost refreshes %.3f s, balance %.3f s, knit "
                  "ghosts %.3f s, the step size's all-reduce %.3f s; packing rows %.3f s of it\n",
                  r.ranks, r.transport.c_str(), r.exchange_seconds,
                  100 * r.exchange_seconds / std::max(1e-9, s.wall_seconds), r.migration_seconds,
                  r.refresh_seconds, r.rebalance_seconds, knit, r.reduction_seconds,
                  r.packing_seconds);
    o << buf;
    if (s.grid_shares[2] > 0) {
      std::snprintf(buf, sizeof buf,
                    "grids: each rank's covers its blocks and the ghosts' reach, %.0f-%.0f%% of "
                    "the domain's cells (mean %.0f%%)\n",
                    100 * s.grid_shares[0], 100 * s.grid_shares[2], 100 * s.grid_shares[1]);
      o << buf;
    }
    if (r.refresh_pass_device[0] + r.refresh_exchange_device[0] > 0) {
      const auto& p = r.refresh_pass_device;
      const auto& x = r.refresh_exchange_device;
      std::snprintf(buf, sizeof buf,
                    "refreshes on the device (rank 0; pass, then the exchange after it): density "
                    "%.3f + %.3f s, walls %.3f + %.3f s, forces %.3f + %.3f s\n",
                    p[0], x[0], p[1], x[1], p[2], x[2]);
      o << buf;
      if (const auto& q = s.refresh_pass_slowest; q[0] + q[1] + q[2] > 0) {
        std::snprintf(buf, sizeof buf,
                      "  the slowest rank's passes (an exchange waits for them): density %.3f s, "
                      "walls %.3f s, forces %.3f s\n",
                      q[0], q[1], q[2]);
        o << buf;
      }
    }
  }
  if (d.knit) {
    std::snprintf(buf, sizeof buf,
                  "knit: %zu points | energy kinetic %.4g J, elastic %.4g J, gravity %.4g J | "
                  "closest approach to a solid %.3g m | contact point-substeps %llu\n",
                  d.knit, d.knit_kinetic_energy, d.knit_elastic_energy, d.knit_potential_energy,
                  d.knit_min_rigid_distance, static_cast<unsigned long long>(d.knit_contacts));
    o << buf;
    std::snprintf(
        buf, sizeof buf,
        "knit self-contact: %llu pairs now, penalty energy %.4g J, closest pair %.3g x 2R\n",
        static_cast<unsigned long long>(d.knit_self_contacts), d.knit_self_energy,
        d.knit_self_min_gap);
    o << buf;
  }
  if (d.knit && d.fluid) {
    std::snprintf(
        buf, sizeof buf,
        "coupling: %llu fluid-knit contacts now (penalty %.4g J) | absorbed fluid %.4g kg "
        "| saturation max %.3f, mean %.4f, %llu wet points | its lists built %llu times\n",
        static_cast<unsigned long long>(d.coupling_contacts), d.coupling_energy, d.absorbed_mass,
        d.max_saturation, d.mean_saturation, static_cast<unsigned long long>(d.wet_points),
        static_cast<unsigned long long>(d.coupling_list_builds));
    o << buf;
    if (d.sheet_corrections) {
      std::snprintf(buf, sizeof buf,
                    "sheet guard: %llu fluid steps through the knit's sheet put back\n",
                    static_cast<unsigned long long>(d.sheet_corrections));
      o << buf;
    }
    if (d.absorbed_particles || d.emitted_particles) {
      std::snprintf(buf, sizeof buf,
                    "absorption: %llu particles absorbed, %llu drops emitted, %.4g kg moved inside "
                    "the knit | free fluid %.6g kg + absorbed %.6g kg + gone %.6g kg = %.6g kg\n",
                    static_cast<unsigned long long>(d.absorbed_particles),
                    static_cast<unsigned long long>(d.emitted_particles), d.diffused_mass,
                    d.fluid_mass, d.absorbed_mass, d.outflow_mass,
                    d.fluid_mass + d.absorbed_mass + d.outflow_mass);
      o << buf;
    }
  }
  if (s.frames)
    o << "snapshots: " << s.frames << " written, last " << s.last_snapshot << "\n";
  if (s.checkpoints)
    o << "checkpoints: " << s.checkpoints << " written, last " << s.last_checkpoint << "\n";
  double total = 0;
  for (const auto& st : s.stages)
    total += st.seconds;
  if (total > 0) {
    const bool slowest = s.stage_seconds_slowest.size() == s.stages.size();
    o << (slowest ? "stages (rank 0's time, share; the slowest rank's time):\n"
                  : "stages (time, share):\n");
    for (std::size_t k = 0; k < s.stages.size(); ++k) {
      const auto& st = s.stages[k];
      std::snprintf(buf, sizeof buf, "  %-22s %9.3f s %6.1f%%", st.name.c_str(), st.seconds,
                    100 * st.seconds / total);
      o << buf;
      if (slowest) {
        std::snprintf(buf, sizeof buf, " %9.3f s", s.stage_seconds_slowest[k]);
        o << buf;
      }
      o << "\n";
    }
    // On the device (--profile-device): each stage's span and the device's wait before it.
    double device_total = 0;
    for (const auto& st : s.stages)
      device_total += st.device_seconds + st.idle_before_seconds;
    if (device_total > 0) {
      const bool slowest_device = s.device_seconds_slowest.size() == s.stages.size();
      o << "stages on the device (rank 0's span from first to last work, share; its wait "
           "before the stage"
        << (slowest_device ? "; the slowest rank's span):\n" : "):\n");
      for (std::size_t k = 0; k < s.stages.size(); ++k) {
        const auto& st = s.stages[k];
        std::snprintf(buf, sizeof buf, "  %-22s %9.3f s %6.1f%% %9.3f s", st.name.c_str(),
                      st.device_seconds, 100 * st.device_seconds / device_total,
                      st.idle_before_seconds);
        o << buf;
        if (slowest_device) {
          std::snprintf(buf, sizeof buf, " %9.3f s", s.device_seconds_slowest[k]);
          o << buf;
        }
        o << "\n";
      }
    }
    // Parts inside the stages (timed only with --profile), as shares of the whole step.
    for (const auto& [name, sec] : stage_parts::totals()) {
      std::snprintf(buf, sizeof buf, "    %-60s %9.3f s %6.1f%%\n", name.c_str(), sec,
                    100 * sec / total);
      o << buf;
    }
  }
  return o.str();
}

} // namespace kf
