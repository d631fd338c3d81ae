#pragma once
// What a run costs before it runs (P7): a model fitted to the accuracy studies' timings
// (jobs/studies/cost_model.py writes src/domain/CostModel.toml; the build compiles it in). A
// run's wall time on a device:
//
//   T = start + steps f (step + (support / 2)^3 fluid N_fluid + boundary N_boundary)
//
// steps from the plan (PlanReport::run_steps), f the product of the factors of the settings the
// scene uses (cost_settings: the continuity density, the neighbour lists, double precision).
// Knit points are not in the model yet (no study has a knit): a scene with a knit says so.
#include "domain/Scene.hpp"
#include "domain/Simulation.hpp"

#include <map>
#include <string>
#include <vector>

namespace kf {

struct DeviceCost {
  std::string name;                      // "h100", "cpu-2core"
  double start_s = 0, step_s = 0;        // a run's start; a step's fixed cost [s]
  double fluid_s = 0, boundary_s = 0;    // a particle's, a step [s]
  std::map<std::string, double> factors; // a setting's (cost_settings' names) on a whole step
  double worst_off = 0;                  // the fit's worst relative error over its runs
};

/// The model compiled in.
const std::vector<DeviceCost>& builtin_cost_model();
/// A model's TOML (a table a device; `source` names it in errors): a kf::Error names the table
/// and key of a missing or negative coefficient.
std::vector<DeviceCost> parse_cost_model(const std::string& text, const std::string& source);

/// The names of the scene's settings that carry a factor: "density_continuity",
/// "neighbour_list_on", "neighbour_list_verlet_settling" or "_flowing" (kept lists last longer
/// where the scene damps its motion toward rest), "precision_double".
std::vector<std::string> cost_settings(const Scene& scene);

struct CostEstimate {
  double step_s = 0, total_s = 0;
};
CostEstimate estimate_cost(const DeviceCost& device, const Scene& scene, const PlanReport& plan);

} // namespace kf
