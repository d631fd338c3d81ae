#pragma once
// What a run costs before it runs (P7): a model fitted to the accuracy studies' timings
// (jobs/studies/cost_model.py writes src/domain/CostModel.toml; the build compiles it in). A
// run's wall time on a device:
//
//   T = start + steps (f (step + (support / 2)^q (pair_step + fluid N_fluid)
//                         + boundary N_boundary)
//                      + knit_step
//                      + substeps (knit_substep + N_knit (knit + self_contact? + coupling?)
//                                  + coupling? coupling_substep)
//                      + coupling? coupling_step
//                      + conserving? darcy_substeps (conserving_substep + N_knit conserving))
//         + knit_start + frames output (N_fluid + N_boundary + N_knit)
//
// steps from the plan (PlanReport::run_steps), q the device's pairs_exponent, f the product of the
// factors of the settings the scene uses (cost_settings: the continuity density, the neighbour
// lists, double precision, particle shifting, the artificial viscosity); the fluid's part where the
// scene has fluid, the knit's where it has a knit, a knit term where the scene calls for its stage
// (knit_cost_terms: self-collision, the knit-fluid coupling and its substep's and step's fixed
// costs, the conserving absorption's Darcy substeps a step), the knit's own fixed costs (a step's:
// its bounds and step size; a run's: building the knit, its pore network and first lists), and the
// snapshots' writing (PlanReport::output_frames). A device fitted to no knit run has no knit terms.
#include "domain/Scene.hpp"
#include "domain/Simulation.hpp"

#include <map>
#include <string>
#include <vector>

namespace kf {

struct DeviceCost {
  std::string name;                   // "h100", "cpu-2core"
  double start_s = 0, step_s = 0;     // a run's start; a step's fixed cost [s]
  double fluid_s = 0, boundary_s = 0; // a particle's, a step [s]
  // A step's cost that grows with the pairs a particle meets, (support / 2)^pairs_exponent, not
  // with the particles: on a GPU a small run's passes last as long as one particle's walk [s].
  double pair_step_s = 0;
  // The pairs' cost against support 2 is (support / 2)^pairs_exponent: 3 where a pair costs as
  // a pair; a GPU fits less (its cells' candidates run longer at a wider support).
  double pairs_exponent = 3;
  std::map<std::string, double> factors; // a setting's (cost_settings' names) on a whole step
  // The knit's: a substep's fixed cost, a point's a substep, the self-contact's and the
  // coupling's a point a substep, the conserving absorption's a point a Darcy substep [s].
  double knit_substep_s = 0, knit_s = 0, self_contact_s = 0, coupling_s = 0, conserving_s = 0;
  double coupling_step_s = 0;      // the coupling's fixed cost a step [s]
  double coupling_substep_s = 0;   // and a substep (its passes' launches) [s]
  double knit_step_s = 0;          // the knit's fixed cost a step [s]
  double knit_start_s = 0;         // and a run's [s]
  double conserving_substep_s = 0; // the conserving absorption's fixed cost a Darcy substep [s]
  double output_s = 0;             // a particle's a snapshot [s]
  bool has_knit_terms() const {
    return knit_substep_s > 0 || knit_s > 0 || knit_step_s > 0 || knit_start_s > 0;
  }
  double worst_off = 0;       // the fit's worst relative error over its runs
  double worst_off_fluid = 0; // the same over its runs without a knit
};

/// The model compiled in.
const std::vector<DeviceCost>& builtin_cost_model();
/// A model's TOML (a table a device; `source` names it in errors): a kf::Error names the table
/// and key of a missing or negative coefficient.
std::vector<DeviceCost> parse_cost_model(const std::string& text, const std::string& source);

/// The names of the scene's settings that carry a factor: "density_continuity",
/// "neighbour_list_on", "neighbour_list_verlet_settling" or "_flowing" (kept lists last longer
/// where the scene damps its motion toward rest), "precision_double", "shifting_fickian",
/// "artificial_viscosity" (alpha > 0).
std::vector<std::string> cost_settings(const Scene& scene);

/// The names of the knit's stages that carry a term: "knit_self_contact", "knit_coupling" (the
/// scene's fluid meets its knit: contact or capillary), "absorption_conserving".
std::vector<std::string> knit_cost_terms(const Scene& scene);

struct CostEstimate {
  double step_s = 0, total_s = 0;
};
CostEstimate estimate_cost(const DeviceCost& device, const Scene& scene, const PlanReport& plan);

} // namespace kf
