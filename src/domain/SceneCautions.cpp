#include "domain/SceneCautions.hpp"

#include <sstream>

namespace kf {

std::vector<std::string> scene_cautions(const Scene& scene) {
  std::vector<std::string> out;
  if (scene.has(Module::Fluid) && scene.solver.kernel == KernelType::CubicSpline &&
      scene.fluid.support > kCubicPairingSupport) {
    std::ostringstream s;
    s << scene.path << ": solver.kernel = \"cubic\" with fluid.support = " << scene.fluid.support
      << " spacings: past " << kCubicPairingSupport
      << " the cubic spline's pairing instability clumps the fluid's particles in pairs (a wave's "
         "period 1.3-2% short at 3); take solver.kernel = \"wendland\" for a wider support "
         "(docs/PHYSICS.md)";
    out.push_back(s.str());
  }
  return out;
}

} // namespace kf
