#pragma once
// Small fluid + knit scenes for the coupling tests, as TOML text.
#include "domain/Simulation.hpp"

#include <string>

namespace kf::test {

/// A 0.1 m knit patch at z = 0.05 in a box without walls, and a fluid block above it.
inline std::string scene_text(const std::string& modules, const std::string& block, double vz,
                              const std::string& extra = "") {
  return R"(
[simulation]
name = "coupling"
end_time = 1.0
gravity = [0, 0, 0]
precision = "double"
modules = [)" +
         modules + R"(]
[domain]
min = [-0.1, -0.1, -0.05]
max = [0.1, 0.1, 0.2]
walls = []
[output]
enabled = false
[solver]
kernel = "cubic"
cfl = 0.2
[fluid]
spacing = 0.005
speed_of_sound = 10.0
viscosity = 0.01
[[fluid.block]]
)" + block +
         R"(
velocity = [0, 0, )" +
         std::to_string(vz) + R"(]
[knit]
thickness = 0.002
mass_per_area = 0.3
damping_ratio = 0.1
[[knit.piece]]
shape = "patch"
center = [0, 0, 0.05]
width = 0.1
height = 0.1
wales = 16
courses = 16
)" + extra;
}

/// Pins along the patch's two y edges: it hangs as a hammock.
inline const char* const kHammockPins = R"(
[[knit.pin]]
min = [-0.06, -0.06, 0]
max = [0.06, -0.049, 0.1]
[[knit.pin]]
min = [-0.06, 0.049, 0]
max = [0.06, 0.06, 0.1]
)";

/// Total momentum of the fluid and the knit (their current masses).
inline Vec3d momentum(const Simulation& sim) {
  Vec3d p{0, 0, 0};
  const io::Frame fr = sim.frame();
  for (const char* phase : {"fluid", "knit"}) {
    const io::Phase* ph = fr.find(phase);
    const auto v = ph->find("velocity")->as<double>();
    const auto m = ph->find("mass")->as<double>();
    for (std::size_t i = 0; i < m.size(); ++i)
      p += Vec3d{v[3 * i], v[3 * i + 1], v[3 * i + 2]} * m[i];
  }
  return p;
}

} // namespace kf::test
