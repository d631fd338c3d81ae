#pragma once
// The progress line of long runs: step, simulated time, dt, particle-steps per second and ETA,
// at most once per `interval` seconds of wall time, on one stream.
#include <chrono>
#include <cstdint>
#include <iosfwd>
#include <string>

namespace kf::io {

class Progress {
public:
  Progress(std::ostream& out, double end_time, double interval_s = 1.0, bool enabled = true);
  /// Called after every step; prints when the interval has passed (or force).
  void update(std::uint64_t step, double t, double dt, std::uint64_t particles, bool force = false);
  /// Text appended to the line from now on (several ranks: their balance and exchange share).
  void set_note(std::string note) { note_ = std::move(note); }
  /// Ends the line (a terminal gets \r updates; a file gets one line each).
  void finish();
  double wall_seconds() const;
  /// particle-steps per second since the start.
  double throughput() const;
  static std::string format_duration(double seconds);

private:
  using clock = std::chrono::steady_clock;
  std::ostream& out_;
  double end_time_, interval_;
  bool enabled_, tty_;
  clock::time_point start_, last_;
  double t_start_ = -1;
  std::uint64_t steps_ = 0;
  double particle_steps_ = 0;
  bool printed_ = false;
  std::string note_;
};

} // namespace kf::io
