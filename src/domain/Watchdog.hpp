#pragma once
// The watchdog (P8): what a run checks every [solver] watchdog_steps steps, besides the
// non-finite values every step's size control catches, so that an explosion is caught while it
// starts, not six hours later. From one cheap reading (Simulation::watch):
// - non-finite energies, speeds or densities;
// - a fluid particle faster than the speed of sound (a weakly compressible fluid is built for
//   speeds an order below it), a knit point faster than anything in the scene could make it;
// - a fluid density error past its bound;
// - kinetic plus gravitational energy past what the run started with (the energy stored in its
//   springs and penalty contacts included) and what was given to it since: the work of the
//   scene's moving solids and handles, measured as the run goes (WatchReading::work), and the
//   most capillary suction can do (its largest pressure times the pore volume). Nothing else
//   adds energy; dissipation only takes it away.
#include "domain/Scene.hpp"
#include "domain/Simulation.hpp"

#include <optional>
#include <string>
#include <vector>

namespace kf {

/// The energy a state holds besides the kinetic and gravitational (a watchdog's start): the
/// knit's springs and the penalty contacts (self, with the fluid) it starts compressed in.
double stored_energy(const Diagnostics& d);

class Watchdog {
public:
  /// Limits for the scene, the energy's from the state a run (or its rollback) starts from.
  Watchdog(const Scene& scene, const WatchReading& start, double start_stored_energy,
           double start_time);

  struct Trip {
    std::string why;                   // the measure, its value, its limit, the key; "": fine
    std::optional<WatchMeasure> worst; // the measure whose worst particle the report describes
  };
  Trip check(const WatchReading& r) const;

  double fluid_speed_limit() const { return fluid_speed_; }
  double knit_speed_limit() const { return knit_speed_; }
  /// The most kinetic plus gravitational energy the run may hold at reading r (its work) [J].
  double energy_limit(const WatchReading& r) const;

private:
  double fluid_speed_ = 0, knit_speed_ = 0, max_density_ = 0, density_error_ = 0;
  double start_energy_ = 0, start_work_ = 0, rise_ = 0, floor_ = 0, capillary_ = 0;
  std::string fluid_hint_; // a known cause of the scene's fluid trips, and its cure ("": none)
};

} // namespace kf
