#include "domain/Watchdog.hpp"

#include "domain/SceneParams.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

namespace kf {

double stored_energy(const Diagnostics& d) {
  return d.knit_elastic_energy + d.knit_self_energy + d.coupling_energy;
}

Watchdog::Watchdog(const Scene& scene, const WatchReading& start, double start_stored_energy,
                   double start_time) {
  const auto& sv = scene.solver;
  const Vec3d span = scene.domain.max - scene.domain.min;
  const double gravity = norm(scene.gravity);
  // The domain's height along g: the farthest anything inside can fall.
  const double height =
      gravity > 0 ? (std::abs(span.x * scene.gravity.x) + std::abs(span.y * scene.gravity.y) +
                     std::abs(span.z * scene.gravity.z)) /
                        gravity
                  : 0.0;
  double move_speed = 0;
  for (const auto& o : scene.obstacles)
    move_speed = std::max(move_speed, norm(o.velocity));
  for (const auto& p : scene.knit.pins)
    if (p.move_until > start_time)
      move_speed = std::max(move_speed, norm(p.velocity));
  double start_speed = 0;
  for (const auto& b : scene.fluid.blocks)
    start_speed = std::max(start_speed, norm(b.velocity));
  for (const auto& p : scene.knit.pieces)
    start_speed = std::max(start_speed, norm(p.velocity));
  const bool fluid = scene.has(Module::Fluid);
  // A knit point falls at most the domain's height, is hit at twice a mover's or its start
  // speed, and carried by the fluid; but a cloth's corners whip (no air drag slows them): the
  // drape's reach 25 m/s, 5.7 times its fall speed (measured, watchdog_steps = 20). Ten times
  // that is past anything a stable run does; an explosion outgrows it within steps.
  const double knit_natural =
      10 * (std::sqrt(2 * gravity * height) + 2 * move_speed + 2 * start_speed);
  if (sv.watchdog_max_speed > 0) {
    fluid_speed_ = knit_speed_ = sv.watchdog_max_speed;
  } else {
    fluid_speed_ = fluid ? scene.fluid.speed_of_sound : 0.0;
    knit_speed_ = std::max(knit_natural, fluid_speed_);
  }
  if (fluid) {
    density_error_ = sv.watchdog_density_error;
    max_density_ = scene.fluid.rest_density * (1 + density_error_);
  }
  start_energy_ = start.kinetic + start.potential + start_stored_energy;
  rise_ = sv.watchdog_energy_rise;
  // A floor for a run that starts with almost no energy: a hundredth of its mass lifted through
  // the domain's height.
  floor_ = 0.01 * start.mass * gravity * height;
  if (scene.has(Module::Capillary) && scene.knit.mass_per_area > 0) {
    // Suction does at most the capillary pressure's largest value, P_c(0) = sigma J(0) /
    // sqrt(kappa / phi) (Eq. 10; J falls as the pores fill), times the pore volume it fills:
    // phi times the knit's volume (its area, dry mass / areal mass, times its thickness). The
    // bound was sigma times the sheet's 6 faces until the wicking study's coarse strip (32 x 4
    // stitches) passed it: this is 25 sigma times its area.
    const double pores = scene.capillary.porosity * scene.knit.thickness * start.knit_mass /
                         scene.knit.mass_per_area;
    capillary_ = capillary_pressure_scale(scene) * leverett_j(0.0) * pores;
  }
  start_work_ = start.work;
  // The summation density without a dissipative term lets the pressure noise at a tank's walls
  // grow until it trips the energy or the speed (a closed tank at rest too, after ~1 s:
  // docs/VALIDATION.md, P7's sloshing); the continuity density's diffusion or Monaghan's term
  // damps it. Named where the scene has that combination.
  if (fluid && sv.density == DensityModel::Summation && scene.fluid.artificial_viscosity == 0)
    fluid_hint_ = "; the summation density without the artificial viscosity lets a tank's "
                  "pressure noise grow until it trips this: set fluid.artificial_viscosity = "
                  "0.01 or solver.density = \"continuity\" (docs/VALIDATION.md)";
}

double Watchdog::energy_limit(const WatchReading& r) const {
  // What the movers and handles did since the start, measured (SimulationT's work_): energy only
  // rises by it; the margin covers rounding and the fluid's compression energy, which the
  // reading leaves out, coming back.
  return (1 + rise_) * (start_energy_ + (r.work - start_work_)) + capillary_ + floor_;
}

Watchdog::Trip Watchdog::check(const WatchReading& r) const {
  char buf[320];
  const bool finite = std::isfinite(r.kinetic) && std::isfinite(r.potential) &&
                      std::isfinite(r.fluid_max_speed) && std::isfinite(r.fluid_max_density) &&
                      std::isfinite(r.knit_max_speed);
  if (!finite) {
    if (!std::isfinite(r.knit_max_speed))
      return {"a knit speed is not finite", WatchMeasure::KnitSpeed};
    if (!std::isfinite(r.fluid_max_density))
      return {"a fluid density is not finite", WatchMeasure::FluidDensity};
    return {"a fluid speed or the energy is not finite", WatchMeasure::FluidSpeed};
  }
  if (fluid_speed_ > 0 && r.fluid_max_speed > fluid_speed_) {
    std::snprintf(buf, sizeof buf,
                  "a fluid particle moves at %.4g m/s, past the watchdog's %.4g m/s "
                  "(solver.watchdog_max_speed; by default the speed of sound)",
                  r.fluid_max_speed, fluid_speed_);
    return {buf + fluid_hint_, WatchMeasure::FluidSpeed};
  }
  if (knit_speed_ > 0 && r.knit_max_speed > knit_speed_) {
    std::snprintf(buf, sizeof buf,
                  "a knit point moves at %.4g m/s, past the watchdog's %.4g m/s "
                  "(solver.watchdog_max_speed; by default ten times what a fall through the "
                  "domain, the movers and the start speeds give)",
                  r.knit_max_speed, knit_speed_);
    return {buf, WatchMeasure::KnitSpeed};
  }
  if (max_density_ > 0 && r.fluid_max_density > max_density_) {
    std::snprintf(buf, sizeof buf,
                  "the fluid's density is %.3g%% off rest, past the watchdog's %.3g%% "
                  "(solver.watchdog_density_error)",
                  100 * (r.fluid_max_density / max_density_ * (1 + density_error_) - 1),
                  100 * density_error_);
    return {buf, WatchMeasure::FluidDensity};
  }
  const double limit = energy_limit(r);
  const double e = r.kinetic + r.potential;
  if (e > limit) {
    std::snprintf(buf, sizeof buf,
                  "the kinetic and gravitational energy rose to %.4g J, past the watchdog's %.4g "
                  "J (the start's %.4g J and the %.4g J the moving solids and handles did since, "
                  "%.3g%% more (solver.watchdog_energy_rise), and what suction could add)",
                  e, limit, start_energy_, r.work - start_work_, 100 * rise_);
    if (r.knit_max_speed > r.fluid_max_speed)
      return {buf, WatchMeasure::KnitSpeed};
    return {buf + fluid_hint_, WatchMeasure::FluidSpeed};
  }
  return {};
}

} // namespace kf
