#include "io/Progress.hpp"

#include <cmath>
#include <cstdio>
#include <iostream>
#include <unistd.h>

namespace kf::io {

Progress::Progress(std::ostream& out, double end_time, double interval_s, bool enabled)
    : out_(out), end_time_(end_time), interval_(interval_s), enabled_(enabled),
      tty_(&out == &std::cerr ? isatty(2) : (&out == &std::cout ? isatty(1) : false)),
      start_(clock::now()), last_(start_) {}

std::string Progress::format_duration(double s) {
  if (!std::isfinite(s) || s < 0)
    return "--:--:--";
  const long v = static_cast<long>(s + 0.5);
  char buf[32];
  std::snprintf(buf, sizeof buf, "%ld:%02ld:%02ld", v / 3600, (v / 60) % 60, v % 60);
  return buf;
}

double Progress::wall_seconds() const {
  return std::chrono::duration<double>(clock::now() - start_).count();
}

double Progress::throughput() const {
  const double w = wall_seconds();
  return w > 0 ? particle_steps_ / w : 0;
}

void Progress::update(std::uint64_t step, double t, double dt, std::uint64_t particles,
                      bool force) {
  if (t_start_ < 0)
    t_start_ = t - dt;
  ++steps_;
  particle_steps_ += static_cast<double>(particles);
  const auto now = clock::now();
  if (!enabled_ || (!force && std::chrono::duration<double>(now - last_).count() < interval_))
    return;
  last_ = now;
  const double wall = wall_seconds();
  const double done = t - t_start_;
  const double eta = done > 0 ? (end_time_ - t) * wall / done : -1;
  char buf[256];
  std::snprintf(buf, sizeof buf,
                "step %8llu | t %.5f / %.5f s | dt %.3e s | %.3e particle-steps/s | ETA %s",
                static_cast<unsigned long long>(step), t, end_time_, dt, throughput(),
                format_duration(eta).c_str());
  out_ << (tty_ ? "\r" : "") << buf << (note_.empty() ? "" : " | ") << note_ << (tty_ ? "" : "\n")
       << std::flush;
  printed_ = true;
}

void Progress::finish() {
  if (enabled_ && tty_ && printed_)
    out_ << "\n" << std::flush;
}

} // namespace kf::io
