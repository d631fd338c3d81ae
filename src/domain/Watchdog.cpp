#include "domain/Watchdog.hpp"

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
  gravity_ = norm(scene.gravity);
  // The domain's height along g: the farthest anything inside can fall.
  const double height =
      gravity_ > 0 ? (std::abs(span.x * scene.gravity.x) + std::abs(span.y * scene.gravity.y) +
                      std::abs(span.z * scene.gravity.z)) /
                         gravity_
                   : 0.0;
  for (const auto& o : scene.obstacles)
    if (norm(o.velocity) > 0)
      movers_.push_back({norm(o.velocity), std::numeric_limits<double>::infinity()});
  for (const auto& p : scene.knit.pins)
    if (p.move_until > start_time && norm(p.velocity) > 0)
      movers_.push_back({norm(p.velocity), p.move_until});
  for (const auto& m : movers_)
    move_speed_ = std::max(move_speed_, m.speed);
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
      10 * (std::sqrt(2 * gravity_ * height) + 2 * move_speed_ + 2 * start_speed);
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
  mass_ = start.mass;
  start_energy_ = start.kinetic + start.potential + start_stored_energy;
  rise_ = sv.watchdog_energy_rise;
  // A floor for a run that starts with almost no energy: a hundredth of its mass lifted through
  // the domain's height.
  floor_ = 0.01 * mass_ * gravity_ * height;
  height_ = height;
  if (scene.has(Module::Capillary) && scene.knit.mass_per_area > 0) {
    // Suction releases at most the surface energy of the wetted pores: sigma times the fibres'
    // area, about the sheet's area (dry knit mass / areal mass) times its layers and both faces.
    capillary_ = 2 * 3 * scene.capillary.sigma * start.knit_mass / scene.knit.mass_per_area;
  }
  start_time_ = start_time;
}

double Watchdog::energy_limit(double t) const {
  // A mover gives at most a bounce at twice its speed and a lift to the domain's top (a piston
  // raises fluid farther than it moves itself: the corner piston's fluid rose 1.15 times what a
  // lift by the piston's travel allows, measured). Coarse, until the movers' work is measured.
  bool moving = false;
  for (const auto& m : movers_)
    moving = moving || std::min(t, m.until) > start_time_;
  const double given =
      (moving ? mass_ * (2 * move_speed_ * move_speed_ + gravity_ * height_) : 0.0) + capillary_;
  return (1 + rise_) * start_energy_ + given + floor_;
}

Watchdog::Trip Watchdog::check(const WatchReading& r, double t) const {
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
    return {buf, WatchMeasure::FluidSpeed};
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
  const double limit = energy_limit(t);
  const double e = r.kinetic + r.potential;
  if (e > limit) {
    std::snprintf(buf, sizeof buf,
                  "the kinetic and gravitational energy rose to %.4g J, past the watchdog's %.4g "
                  "J (the start's %.4g J, %.3g%% more (solver.watchdog_energy_rise), and what "
                  "movers and suction could add)",
                  e, limit, start_energy_, 100 * rise_);
    return {buf, r.knit_max_speed > r.fluid_max_speed ? WatchMeasure::KnitSpeed
                                                      : WatchMeasure::FluidSpeed};
  }
  return {};
}

} // namespace kf
