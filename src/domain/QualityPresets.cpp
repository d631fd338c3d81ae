// The [solver] quality presets (P7): what each trades, from the studies' Pareto fronts
// (jobs/studies/accuracy.py; docs/VALIDATION.md states each preset's error and cost).
#include "domain/Scene.hpp"

namespace kf {

QualityPreset quality_preset(Scene::Solver::Quality q) {
  using Q = Scene::Solver::Quality;
  QualityPreset p;
  switch (q) {
  case Q::Preview:
    // Twice the spacing (an eighth of the particles, half the steps) and the cheaper settings
    // that cost no accuracy (H100 studies): the continuity density (one neighbour pass a step;
    // at coarse spacings more accurate too), lists kept over steps (half the time), CFL 0.3.
    // The knit-fluid contact as stiff as at the scene's spacing: where it limits the step (the
    // knit's substep against a fluid particle), a stiffer one for the heavier particles made
    // the preview of the pour and the wicking strip slower than production.
    p.spacing_scale = 2;
    p.contact_at_scene_spacing = true;
    p.cfl = 0.3;
    p.density = DensityModel::Continuity;
    p.neighbour_list = Scene::Solver::NeighbourLists::Verlet;
    break;
  case Q::Reference:
    // Half the spacing and twice the speed of sound (a quarter of the weak compressibility's
    // density error, which floors the error at fine spacings: the hydrostatic tank's 0.39% at
    // c = 20 m/s against 0.24% at 40): the error of the scene's own resolution is measured
    // against it. A smaller CFL number and double precision bought nothing measurable.
    p.spacing_scale = 0.5;
    p.sound_speed_scale = 2;
    break;
  case Q::Production:
  case Q::None:
    break;
  }
  return p;
}

std::string to_string(Scene::Solver::Quality q) {
  switch (q) {
  case Scene::Solver::Quality::Preview:
    return "preview";
  case Scene::Solver::Quality::Production:
    return "production";
  case Scene::Solver::Quality::Reference:
    return "reference";
  case Scene::Solver::Quality::None:
    break;
  }
  return "none";
}

} // namespace kf
