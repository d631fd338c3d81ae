#pragma once
// The stages one time step runs, built from the modules a scene asks for: a scene without fluid
// has no SPH stage, and so on. Each stage keeps its call count and time for the profile.
#include <cstdint>
#include <functional>
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
    double seconds = 0;
    std::uint64_t calls = 0;
  };

  void add(std::string name, std::string module, std::string what, std::function<void()> run);
  /// Runs every stage in order; with a synchronising `timer_sync` each stage's time is measured.
  void run(const std::function<void()>& timer_sync = {});
  const std::vector<Stage>& stages() const { return stages_; }
  bool has(const std::string& name) const;
  bool has_module(const std::string& module) const;

private:
  std::vector<Stage> stages_;
};

} // namespace kf
