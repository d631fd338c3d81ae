#include "domain/CostModel.hpp"

#include "core/Error.hpp"
#include "domain/CostModelData.hpp"

#include <toml++/toml.h>

#include <algorithm>
#include <cmath>
#include <iterator>
#include <utility>

namespace kf {

std::vector<DeviceCost> parse_cost_model(const std::string& text, const std::string& source) {
  toml::table root;
  try {
    root = toml::parse(text, std::string_view(source));
  } catch (const toml::parse_error& e) {
    throw Error(source + ": " + std::string(e.description()));
  }
  std::vector<DeviceCost> out;
  for (const auto& [name, node] : root) {
    const toml::table* t = node.as_table();
    if (!t)
      throw Error(source + ": '" + std::string(name.str()) + "' is not a device's table");
    DeviceCost d;
    d.name = std::string(name.str());
    const auto coefficient = [&](const char* key, bool required) {
      const auto v = (*t)[key].value<double>();
      if (!v && required)
        throw Error(source + ": [" + d.name + "] has no '" + key + "' (a number of seconds)");
      if (v && !(*v >= 0))
        throw Error(source + ": [" + d.name + "] '" + key + "' must be >= 0, not " +
                    std::to_string(*v));
      return v.value_or(0.0);
    };
    d.start_s = coefficient("start_s", true);
    d.step_s = coefficient("step_s", true);
    d.fluid_s = coefficient("fluid_s", true);
    d.boundary_s = coefficient("boundary_s", true);
    d.worst_off = coefficient("worst_off", false);
    d.worst_off_fluid = coefficient("worst_off_fluid", false);
    // The coefficients a device may lack (a fit without knit runs, an older table): zero.
    const std::pair<const char*, double*> optional[] = {
        {"pair_step_s", &d.pair_step_s},
        {"knit_substep_s", &d.knit_substep_s},
        {"knit_s", &d.knit_s},
        {"self_contact_s", &d.self_contact_s},
        {"coupling_s", &d.coupling_s},
        {"conserving_s", &d.conserving_s},
        {"output_s", &d.output_s},
        {"coupling_step_s", &d.coupling_step_s},
        {"coupling_substep_s", &d.coupling_substep_s},
        {"knit_step_s", &d.knit_step_s},
        {"knit_start_s", &d.knit_start_s},
        {"conserving_substep_s", &d.conserving_substep_s}};
    for (const auto& [key, at] : optional)
      *at = coefficient(key, false);
    if ((*t)["pairs_exponent"])
      d.pairs_exponent = coefficient("pairs_exponent", true);
    for (const auto& [key, value] : *t) {
      const std::string k(key.str());
      if (k == "start_s" || k == "step_s" || k == "fluid_s" || k == "boundary_s" ||
          k == "worst_off" || k == "worst_off_fluid" || k == "pairs_exponent" ||
          std::any_of(std::begin(optional), std::end(optional),
                      [&](const auto& e) { return k == e.first; }))
        continue;
      d.factors[k] = coefficient(k.c_str(), true);
    }
    out.push_back(std::move(d));
  }
  return out;
}

const std::vector<DeviceCost>& builtin_cost_model() {
  static const std::vector<DeviceCost> model =
      parse_cost_model(generated::kCostModelToml, "src/domain/CostModel.toml");
  return model;
}

std::vector<std::string> cost_settings(const Scene& scene) {
  std::vector<std::string> out;
  const auto& s = scene.solver;
  if (s.density == DensityModel::Continuity)
    out.push_back("density_continuity");
  if (s.neighbour_list == Scene::Solver::NeighbourLists::On)
    out.push_back("neighbour_list_on");
  if (s.neighbour_list == Scene::Solver::NeighbourLists::Verlet)
    out.push_back(s.damping > 0 ? "neighbour_list_verlet_settling"
                                : "neighbour_list_verlet_flowing");
  if (scene.precision == Precision::Double)
    out.push_back("precision_double");
  if (s.shifting == Scene::Solver::Shifting::Fickian && scene.has(Module::Fluid))
    out.push_back("shifting_fickian");
  // Its own instantiation of the forces pass: a few flops a fluid pair (CPU +17-28%, H200 ~1%).
  if (scene.fluid.artificial_viscosity > 0 && scene.has(Module::Fluid))
    out.push_back("artificial_viscosity");
  return out;
}

std::vector<std::string> knit_cost_terms(const Scene& scene) {
  std::vector<std::string> out;
  if (!scene.has(Module::Knit))
    return out;
  if (scene.knit.self_collision)
    out.push_back("knit_self_contact");
  const bool coupled =
      scene.has(Module::Fluid) && (scene.has(Module::Contact) || scene.has(Module::Capillary));
  if (coupled)
    out.push_back("knit_coupling");
  if (coupled && scene.has(Module::Capillary) &&
      scene.capillary.model == Scene::AbsorptionModel::Conserving)
    out.push_back("absorption_conserving");
  return out;
}

CostEstimate estimate_cost(const DeviceCost& device, const Scene& scene, const PlanReport& plan) {
  double f = 1;
  for (const std::string& name : cost_settings(scene)) {
    const auto it = device.factors.find(name);
    if (it != device.factors.end())
      f *= it->second;
  }
  const double pairs = std::pow(scene.fluid.support / 2.0, device.pairs_exponent);
  CostEstimate e;
  if (plan.fluid > 0 || plan.boundary > 0)
    e.step_s =
        f * (device.step_s + pairs * (device.pair_step_s + device.fluid_s * double(plan.fluid)) +
             device.boundary_s * double(plan.boundary));
  if (plan.knit > 0) {
    const double n = double(plan.knit);
    double point = device.knit_s, per_substep = device.knit_substep_s,
           per_step = device.knit_step_s;
    for (const std::string& term : knit_cost_terms(scene)) {
      if (term == "knit_self_contact")
        point += device.self_contact_s;
      else if (term == "knit_coupling") {
        point += device.coupling_s;
        per_substep += device.coupling_substep_s;
        per_step += device.coupling_step_s;
      } else if (term == "absorption_conserving")
        per_step += std::max(1.0, plan.darcy_substeps) *
                    (device.conserving_substep_s + device.conserving_s * n);
    }
    e.step_s += double(scene.knit.substeps) * (per_substep + n * point) + per_step;
  }
  e.total_s = device.start_s + (plan.knit > 0 ? device.knit_start_s : 0.0) +
              plan.run_steps * e.step_s +
              plan.output_frames * device.output_s * double(plan.fluid + plan.boundary + plan.knit);
  return e;
}

} // namespace kf
