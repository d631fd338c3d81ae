#pragma once
// The stages one time step runs, built from the modules a scene asks for: a scene without fluid
// has no SPH stage, and so on. Each stage keeps its call count and time for the profile.
#include "kernels/exec/Stopwatch.hpp"

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace kf {

class Pipeline {
public:
  struct Stage {
    std::string name;   // "sph.density"
    std::string module; // "fluid"
    std::string what;   // one line for `plan`
    std::function<void()> run;
    // Runs before the step's size is known: queues no work that takes it (run() with a
    // settle_dt waits for the size only at the first stage that is not).
    bool before_dt = false;
    double seconds = 0;
    std::uint64_t calls = 0;
    // Timed on the device (time_on_device): the span from the stage's first work to its last,
    // and the device's wait before that first work (the host still queuing it).
    double device_seconds = 0, idle_before_seconds = 0;
  };

  void add(std::string name, std::string module, std::string what, std::function<void()> run,
           bool before_dt = false);
  /// Runs every stage in order; with a synchronising `timer_sync` each stage's time is measured.
  /// `settle_dt`, when given, is called before each stage that is not before_dt (it makes the
  /// step's size known; a no-op once it is).
  void run(const std::function<void()>& timer_sync = {},
           const std::function<void()>& settle_dt = {});
  /// From now on each stage is also timed on the backend's stream, without waiting for it
  /// (events read every few hundred steps, and at collect_device()): where the device works and
  /// where it waits for the host (P9: a split step's time that host timings cannot place).
  void time_on_device(exec::Backend backend);
  /// Adds the device's intervals read so far into the stages' device and idle seconds.
  void collect_device();
  const std::vector<Stage>& stages() const { return stages_; }
  bool has(const std::string& name) const;
  bool has_module(const std::string& module) const;

private:
  std::vector<Stage> stages_;
  // Per stage, with time_on_device: its span, and the wait before it (opened after the stage
  // before it, the last stage's for the first).
  std::vector<std::unique_ptr<exec::Stopwatch>> spans_, waits_;
  std::size_t runs_since_collect_ = 0;
  std::size_t open_wait_ = std::size_t(-1); // the wait opened after the last stage run
};

} // namespace kf
