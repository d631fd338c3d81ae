#include "domain/Pipeline.hpp"

#include "core/Error.hpp"

#include <chrono>

namespace kf {

void Pipeline::add(std::string name, std::string module, std::string what,
                   std::function<void()> run, bool before_dt) {
  stages_.push_back(
      {std::move(name), std::move(module), std::move(what), std::move(run), before_dt, 0, 0});
}

void Pipeline::time_on_device(exec::Backend backend) {
  spans_.clear();
  waits_.clear();
  open_wait_ = std::size_t(-1);
  for (std::size_t k = 0; k < stages_.size(); ++k) {
    spans_.push_back(std::make_unique<exec::Stopwatch>(backend));
    waits_.push_back(std::make_unique<exec::Stopwatch>(backend));
  }
}

void Pipeline::collect_device() {
  for (std::size_t k = 0; k < spans_.size(); ++k) {
    stages_[k].device_seconds += spans_[k]->collect();
    stages_[k].idle_before_seconds += waits_[k]->collect();
  }
  runs_since_collect_ = 0;
}

void Pipeline::run(const std::function<void()>& timer_sync,
                   const std::function<void()>& settle_dt) {
  using clock = std::chrono::steady_clock;
  const bool on_device = !spans_.empty();
  for (std::size_t k = 0; k < stages_.size(); ++k) {
    auto& s = stages_[k];
    const auto t0 = clock::now();
    // Before the device's span: an instability found there is the step's, not the stage's.
    if (settle_dt && !s.before_dt)
      settle_dt();
    if (on_device) {
      if (open_wait_ < waits_.size()) // none before the first stage's first run
        waits_[open_wait_]->stop();
      spans_[k]->start();
    }
    // The intervals stay paired when a stage throws (a run recovered by the watchdog goes on).
    const auto close_span = [&] {
      if (on_device) {
        spans_[k]->stop();
        open_wait_ = (k + 1) % stages_.size();
        waits_[open_wait_]->start();
      }
    };
    try {
      s.run();
    } catch (const InstabilityError& e) { // names its step and particle: add the stage
      close_span();
      throw InstabilityError(std::string(e.what()) + "; in stage '" + s.name + "' [" + s.module +
                             "]");
    } catch (const Error& e) {
      // A device failure (out of memory, a failed launch) names its buffer or kernel and size;
      // the stage says where in the step it happened.
      close_span();
      throw Error("stage '" + s.name + "' [" + s.module + "]: " + e.what());
    }
    close_span();
    if (timer_sync)
      timer_sync();
    s.seconds += std::chrono::duration<double>(clock::now() - t0).count();
    ++s.calls;
  }
  // Two events a stage and a run: read every 256 runs (one host wait), so the lists stay short.
  if (on_device && ++runs_since_collect_ >= 256)
    collect_device();
}

bool Pipeline::has(const std::string& name) const {
  for (const auto& s : stages_)
    if (s.name == name)
      return true;
  return false;
}

bool Pipeline::has_module(const std::string& module) const {
  for (const auto& s : stages_)
    if (s.module == module)
      return true;
  return false;
}

} // namespace kf
