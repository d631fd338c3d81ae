#include "domain/CostModel.hpp"

#include "core/Error.hpp"
#include "domain/CostModelData.hpp"

#include <toml++/toml.h>

#include <cmath>

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
    for (const auto& [key, value] : *t) {
      const std::string k(key.str());
      if (k == "start_s" || k == "step_s" || k == "fluid_s" || k == "boundary_s" ||
          k == "worst_off")
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
  return out;
}

CostEstimate estimate_cost(const DeviceCost& device, const Scene& scene, const PlanReport& plan) {
  double f = 1;
  for (const std::string& name : cost_settings(scene)) {
    const auto it = device.factors.find(name);
    if (it != device.factors.end())
      f *= it->second;
  }
  const double pairs = std::pow(scene.fluid.support / 2.0, 3);
  CostEstimate e;
  e.step_s = f * (device.step_s + pairs * device.fluid_s * double(plan.fluid) +
                  device.boundary_s * double(plan.boundary));
  e.total_s = device.start_s + plan.run_steps * e.step_s;
  return e;
}

} // namespace kf
