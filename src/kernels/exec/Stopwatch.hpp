#pragma once
// The time of work queued on a backend, summed over many intervals without waiting for it: on a
// device each interval is a pair of events in the stream, read back only at collect(), so timing
// a pass does not stall the host behind its kernels (a rank that waits there cannot post its
// halo exchange while the GPU computes). On the CPU the work is done when the calls return: the
// host's clock.
#include "kernels/exec/Backend.hpp"

#include <chrono>
#include <cstddef>
#include <vector>

namespace kf::exec {

class Stopwatch {
public:
  explicit Stopwatch(Backend b) : backend_(b) {}
  ~Stopwatch();
  Stopwatch(const Stopwatch&) = delete;
  Stopwatch& operator=(const Stopwatch&) = delete;

  Backend backend() const { return backend_; }
  /// Opens an interval: the work queued from now on.
  void start();
  /// Closes the interval start() opened, after the work queued so far.
  void stop();
  /// Seconds of the intervals closed since the last collect (waits for the last one's work).
  double collect();

private:
  Backend backend_;
  bool open_ = false;
  double host_seconds_ = 0;
  std::chrono::steady_clock::time_point t0_{};
  // A device's events: intervals [2k, 2k + 1] of the first `used_` / 2 pairs since the last
  // collect; kept for reuse.
  std::vector<void*> events_;
  std::size_t used_ = 0;
};

} // namespace kf::exec
