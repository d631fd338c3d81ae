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
  if (scene.solver.quality == Scene::Solver::Quality::Preview && scene.has(Module::Knit) &&
      scene.has(Module::Fluid)) {
    // Measured on an H200 (docs/VALIDATION.md, the presets): the knit's step, most of a coupled
    // scene's, costs as much or more beside the coarser fluid.
    std::ostringstream s;
    s << scene.path
      << ": solver.quality = \"preview\" coarsens the fluid only; the knit is "
         "simulated as written, and on a GPU its work is most of a coupled scene's step: there the "
         "preview is no faster than the scene as written (an H200: the pour 15.1 s against 12.6 "
         "s, the wicking strip 27.5 s against 25.4 s); on CPUs it halves the pour's time";
    out.push_back(s.str());
  }
  return out;
}

} // namespace kf
