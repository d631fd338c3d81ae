#include "domain/Pipeline.hpp"

#include "core/Error.hpp"

#include <chrono>

namespace kf {

void Pipeline::add(std::string name, std::string module, std::string what,
                   std::function<void()> run) {
  stages_.push_back({std::move(name), std::move(module), std::move(what), std::move(run), 0, 0});
}

void Pipeline::run(const std::function<void()>& timer_sync) {
  using clock = std::chrono::steady_clock;
  for (auto& s : stages_) {
    const auto t0 = clock::now();
    try {
      s.run();
    } catch (const InstabilityError& e) { // names its step and particle: add the stage
      throw InstabilityError(std::string(e.what()) + "; in stage '" + s.name + "' [" + s.module +
                             "]");
    } catch (const Error& e) {
      // A device failure (out of memory, a failed launch) names its buffer or kernel and size;
      // the stage says where in the step it happened.
      throw Error("stage '" + s.name + "' [" + s.module + "]: " + e.what());
    }
    if (timer_sync)
      timer_sync();
    s.seconds += std::chrono::duration<double>(clock::now() - t0).count();
    ++s.calls;
  }
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
