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

/// A piston sweeps a closed tank, the water column L = 0.18 m long (x), w = 0.04 m wide and
/// d = 0.05 m deep, at u = 0.1 m/s (Froude u / sqrt(g d) = 0.14: nearly quasi-static) until
/// end_time, the column shortening to L - u t and deepening to d L / (L - u t). Continuity
/// density: summation's walls add energy of their own (docs/VALIDATION.md, P8). Double.
inline Scene piston_scene(double dp, double end_time) {
  return parse_scene(R"(
[simulation]
name = "piston"
end_time = )" + std::to_string(end_time) +
                         R"(
precision = "double"
modules = ["fluid", "boundary"]
[domain]
min = [0, 0, 0]
max = [0.2, 0.04, 0.15]
[output]
enabled = false
[solver]
kernel = "cubic"
cfl = 0.2
density = "continuity"
[fluid]
spacing = )" + std::to_string(dp) +
                         R"(
eos = "tait"
speed_of_sound = 20.0
viscosity = 0.001
[[fluid.block]]
min = [0.02, 0, 0]
max = [0.2, 0.04, 0.05]
[[obstacle]]
name = "piston"
shape = "box"
min = [-0.2, -0.1, -0.1]
max = [0.02, 0.14, 0.3]
velocity = [0.1, 0, 0]
)",
                     "<piston>");
}

} // namespace kf::test
