// The cost model (P7, domain/CostModel): the compiled-in coefficients read; a bad model file is
// refused naming its table and key; the plan's steps for the run (the CFL step at the fluid's
// fall speed, or at rest for a settling scene) match a run's steps; and an estimate composes the
// settings' factors as the model says.
#include "core/Error.hpp"
#include "domain/CostModel.hpp"
#include "domain/Scene.hpp"
#include "domain/Simulation.hpp"
#include "support/TestPaths.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

using namespace kf;

namespace {

std::string scene_path(const char* name) {
  return (test::source_dir() / "scenes" / name).string();
}

/// Steps a run of the scene takes to its end (the CPU backend).
long steps_of(const Scene& s) {
  auto sim = Simulation::create(s, exec::Backend::Cpu);
  long n = 0;
  while (sim->time() < s.end_time - 1e-12) {
    sim->step(s.end_time);
    ++n;
  }
  return n;
}

} // namespace

TEST(CostModel, TheCompiledInModelHasTheStudiedDevices) {
  const auto& model = builtin_cost_model();
  for (const char* name : {"h100", "cpu-2core"}) {
    const auto it = std::find_if(model.begin(), model.end(),
                                 [&](const DeviceCost& d) { return d.name == name; });
    ASSERT_NE(it, model.end()) << name;
    EXPECT_GT(it->start_s, 0) << name;
    EXPECT_GT(it->step_s, 0) << name;
    EXPECT_GT(it->fluid_s, 0) << name;
    // The fit is checked against the studies' runs: within 25% (the bound).
    EXPECT_LE(it->worst_off, 0.25) << name;
  }
}

TEST(CostModel, ABadModelNamesItsTableAndKey) {
  const auto message = [](const std::string& text) {
    try {
      parse_cost_model(text, "model.toml");
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("(no error)");
  };
  const std::string missing = message("[gpu]\nstart_s = 1\nstep_s = 1\nfluid_s = 1\n");
  EXPECT_NE(missing.find("model.toml: [gpu] has no 'boundary_s'"), std::string::npos) << missing;
  const std::string negative = message(
      "[gpu]\nstart_s = 1\nstep_s = 1\nfluid_s = 1\nboundary_s = 0\nprecision_double = -2\n");
  EXPECT_NE(negative.find("'precision_double' must be >= 0"), std::string::npos) << negative;
}

TEST(CostModel, ThePlansStepsAreARunsSteps) {
  // The dam break falls: its steps shrink with the flow's speed, which the plan takes as the
  // free fall from the column's top (2.8 m/s against c = 30 m/s): 985 planned to 0.3 s at
  // 0.025 m, 966 run (2.0% fewer: the flow's top speed stays under the free fall's most of the
  // way). The hydrostatic tank settles under damping: at rest, the initial step throughout (750
  // planned, 760 run: the last step cut short, the step's other limits). Bound 3%; without the
  // fall speed the dam break's plan is 7% short (900).
  struct Case {
    const char* scene;
    std::vector<std::string> overrides;
  };
  for (const Case& c :
       {Case{"dambreak.toml", {"fluid.spacing=0.025", "simulation.end_time=0.3"}},
        Case{"hydrostatic.toml", {"fluid.spacing=0.02", "simulation.end_time=0.3"}}}) {
    SCOPED_TRACE(c.scene);
    std::vector<std::string> o = c.overrides;
    o.push_back("output.enabled=false");
    const Scene s = load_scene(scene_path(c.scene), o);
    const PlanReport plan = Simulation::plan(s);
    const long steps = steps_of(s);
    std::printf("%s: %.0f steps planned, %ld run\n", c.scene, plan.run_steps, steps);
    EXPECT_NEAR(plan.run_steps, double(steps), 0.03 * double(steps));
  }
}

TEST(CostModel, AnEstimateComposesTheSettingsFactors) {
  DeviceCost d;
  d.start_s = 2;
  d.step_s = 1e-4;
  d.fluid_s = 1e-8;
  d.boundary_s = 1e-9;
  d.factors = {{"density_continuity", 0.8},
               {"neighbour_list_verlet_flowing", 0.5},
               {"neighbour_list_verlet_settling", 0.25}};
  const Scene base = load_scene(scene_path("dambreak.toml"), {"fluid.spacing=0.02"});
  const PlanReport p = Simulation::plan(base);
  const double step = 1e-4 + 1e-8 * double(p.fluid) + 1e-9 * double(p.boundary);
  EXPECT_NEAR(estimate_cost(d, base, p).total_s, 2 + p.run_steps * step, 1e-9);
  const Scene both = load_scene(
      scene_path("dambreak.toml"),
      {"fluid.spacing=0.02", "solver.density=\"continuity\"", "solver.neighbour_list=\"verlet\""});
  EXPECT_EQ(cost_settings(both),
            (std::vector<std::string>{"density_continuity", "neighbour_list_verlet_flowing"}));
  EXPECT_NEAR(estimate_cost(d, both, p).step_s, 0.8 * 0.5 * step, 1e-12);
  // Damping marks a settling scene: its kept lists are the settling factor's.
  const Scene settling = load_scene(scene_path("dambreak.toml"),
                                    {"fluid.spacing=0.02", "solver.neighbour_list=\"verlet\"",
                                     "solver.damping=1.0", "solver.damping_until=0.1"});
  EXPECT_EQ(cost_settings(settling), (std::vector<std::string>{"neighbour_list_verlet_settling"}));
  // A wider support meets (support / 2)^3 as many pairs: the fluid's term scales.
  const Scene wide =
      load_scene(scene_path("dambreak.toml"), {"fluid.spacing=0.02", "fluid.support=2.5"});
  const PlanReport pw = Simulation::plan(wide);
  EXPECT_NEAR(estimate_cost(d, wide, pw).step_s,
              1e-4 + std::pow(1.25, 3) * 1e-8 * double(pw.fluid) + 1e-9 * double(pw.boundary),
              1e-12);
}
