#pragma once
// Small scenes built in code for physics tests (the scene files in scenes/ are tested through
// the loader; these keep the physics tests independent of the TOML layer).
#include "domain/Scene.hpp"

#include <string>

namespace kf::test {

/// A closed tank [0, size] with one fluid block [0, fill] and no output.
inline Scene tank_scene(const Vec3d& size, const Vec3d& fill, double dp) {
  Scene s;
  s.name = "tank";
  s.modules = {Module::Fluid, Module::Boundary};
  s.domain.min = {0, 0, 0};
  s.domain.max = size;
  s.fluid.spacing = dp;
  s.fluid.blocks.push_back({{0, 0, 0}, fill, {0, 0, 0}});
  s.output.enabled = false;
  return s;
}

/// A block of fluid thrown at 2 m/s along +x inside a 0.2 x 0.1 x 0.1 m box, no gravity, double;
/// `walls` lists the box's walled sides (TOML strings), `solver` adds [solver] keys.
inline Scene jet_scene(const std::string& walls, const std::string& solver = "") {
  return parse_scene(R"(
[simulation]
name = "outflow"
end_time = 1.0
gravity = [0, 0, 0]
precision = "double"
modules = ["fluid", "boundary"]
[domain]
min = [0, 0, 0]
max = [0.2, 0.1, 0.1]
walls = [)" + walls + R"(]
[output]
enabled = false
[solver]
kernel = "cubic"
)" + solver + R"(
[fluid]
spacing = 0.01
speed_of_sound = 20.0
[[fluid.block]]
min = [0.12, 0.03, 0.03]
max = [0.18, 0.07, 0.07]
velocity = [2.0, 0, 0]
)",
                     "<outflow>");
}

} // namespace kf::test
