#pragma once
// Small scenes built in code for physics tests (the scene files in scenes/ are tested through
// the loader; these keep the physics tests independent of the TOML layer).
#include "domain/Scene.hpp"

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

} // namespace kf::test
