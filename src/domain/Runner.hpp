#pragma once
// Runs a scene from start (or a restart snapshot) to its end time: steps, snapshots at the output
// cadence, the progress line and the closing summary. The `knitflow run` command is a thin layer
// over this.
#include "comm/MpiContext.hpp"
#include "domain/Scene.hpp"
#include "domain/Simulation.hpp"
#include "kernels/exec/Backend.hpp"
#include "kernels/exec/PeakByLabel.hpp"

#include <array>
#include <iosfwd>
#include <string>
#include <vector>

namespace kf {

struct RunOptions {
  exec::Backend backend = exec::Backend::Cpu;
  std::string restart; // snapshot to continue from ("" = start at t = 0; "latest": the newest
                       // complete checkpoint or frame in the scene's output directory)
  bool progress = true;
  double progress_interval_s = 1.0;
  bool profile = false;        // time each stage (synchronises the device after each)
  bool profile_device = false; // time each stage on the device too, without synchronising
  double stop_time = -1;       // stop early at this simulated time (< 0: scene end time)
  // A fault injected on purpose (the tests of a job's failure; KF_FAULT="rank:step:kind"): on
  // rank `rank`, once `step` steps are done, "error" throws, "abort" and "segv" raise the signal.
  struct Fault {
    int rank = -1;
    std::uint64_t step = 0;
    std::string kind;
  } fault;
};

/// Parses KF_FAULT ("rank:step:kind", kind error | instability | abort | segv; instability: an
/// InstabilityError, once a process); empty text: no fault.
RunOptions::Fault parse_fault(const std::string& text);

struct RunSummary {
  std::uint64_t steps = 0; // steps taken by this run (not counting those before a restart)
  double sim_time = 0;     // simulated time reached
  double wall_seconds = 0;
  double particle_steps_per_s = 0;
  std::uint64_t frames = 0; // snapshots written by this run
  std::string last_snapshot;
  std::uint64_t checkpoints = 0; // checkpoints written by this run
  std::string last_checkpoint;
  std::uint64_t rollbacks = 0; // returns to the last checkpoint (on_instability = "rollback")
  Diagnostics diagnostics;
  std::vector<Pipeline::Stage> stages; // with their times when profiled (run functions dropped)
  Simulation::RankReport split;        // this rank's (rank 0's in the log) on N ranks
  std::vector<double> stage_seconds_slowest;  // each stage's largest time over the ranks (rank 0,
                                              // N ranks, profiled)
  std::vector<double> device_seconds_slowest; // the same for the device spans (--profile-device)
  // Each refresh's pass on the slowest rank (rank 0, N ranks, --profile-device): an exchange
  // waits for the slowest rank's pass, so rank 0's exchange is that minus its own pass plus the
  // transfer.
  decltype(Simulation::RankReport::refresh_pass_device) refresh_pass_slowest{};
  // The ranks' grids over the domain's cells: the smallest, the mean and the largest share.
  std::array<double, 3> grid_shares{};
  // The most the backend held at once (exec::held_bytes) on a rank: the largest over the
  // ranks and their mean (rank 0).
  std::array<double, 2> peak_bytes{};
  // The process's resident peak (getrusage's ru_maxrss) the same way: what the host held, set-up
  // included (each rank samples only its share of the scene), and on the CPU backend its
  // buffers too.
  std::array<double, 2> host_peak_bytes{};
  // What the backend held at its peak by buffer (exec::peak_by_label; rank 0's, profiled runs).
  std::vector<exec::LabelledBytes> peak_by_label;
  exec::Backend backend = exec::Backend::Cpu;
};

RunSummary run_scene(const Scene& scene, const RunOptions& opt, const comm::MpiContext& mpi,
                     std::ostream& log);

/// The closing summary as text (steps, time, throughput, snapshots, diagnostics, stage shares).
std::string format_summary(const RunSummary& s);

} // namespace kf
