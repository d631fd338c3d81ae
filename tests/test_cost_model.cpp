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
#include <filesystem>
#include <string>
#include <tuple>

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

/// A device with the fluid's coefficients (no settings' factors, no knit terms).
DeviceCost fluid_device(double start_s) {
  DeviceCost d;
  d.start_s = start_s;
  d.step_s = 1e-4;
  d.fluid_s = 1e-8;
  d.boundary_s = 1e-9;
  return d;
}

} // namespace

TEST(CostModel, TheCompiledInModelHasTheStudiedDevices) {
  const auto& model = builtin_cost_model();
  for (const char* name : {"h100", "h200", "cpu-2core"}) {
    const auto it = std::find_if(model.begin(), model.end(),
                                 [&](const DeviceCost& d) { return d.name == name; });
    ASSERT_NE(it, model.end()) << name;
    EXPECT_GT(it->start_s, 0) << name;
    EXPECT_GT(it->fluid_s + it->boundary_s, 0) << name;
    // The fit is checked against the studies' runs: those without a knit within 25% (the
    // issue's bound; measured 21% H100 (2026-12-06, fifth: every study case's full runs on one
    // H100; the sloshing's small tanks -21%, 10% without them),
    // 22% H200 (the sloshing's smallest tank, 600 particles, -22%; the support's exponent and a
    // step's cost a pair fitted 2026-12-01),
    // 19% the 2-core CPU). The CPU's tank runs whose single timings missed (support 1.5 and
    // 2.5, the kernels: 27-33%) are the medians of three since 2026-12-01
    // (jobs/studies/repeated.py): identical runs on that VM vary by +-15%.
    const double fluid = it->worst_off_fluid > 0 ? it->worst_off_fluid : it->worst_off;
    EXPECT_LE(fluid, 0.25) << name;
  }
  // The knit's terms, fitted on every device (minimax on the knit's runs): the H100's worst
  // over its 138 runs 21% (2026-12-06; the drape at 256 stitches, the wicking strip's ends of
  // its axes); the H200's over 138 runs 22% (2026-12-06, sixth: the wicking strip's study rerun,
  // its runs within 18%; the catenary and the drape at their finest -21%, the sloshing's smallest
  // tank -22%; the knit's fixed costs a step and a run, the conserving model's a Darcy substep:
  // 34% without them); the CPU's 49 runs within 19% (its knit runs within 12%).
  for (const char* name : {"h100", "h200", "cpu-2core"}) {
    const auto it = std::find_if(model.begin(), model.end(),
                                 [&](const DeviceCost& d) { return d.name == name; });
    ASSERT_NE(it, model.end());
    EXPECT_TRUE(it->has_knit_terms()) << name;
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
  DeviceCost d = fluid_device(2);
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
  // Monaghan's artificial viscosity, where alpha > 0, with shifting: both priced, each a factor.
  d.factors["artificial_viscosity"] = 1.25;
  d.factors["shifting_fickian"] = 1.5;
  const Scene viscous = load_scene(
      scene_path("dambreak.toml"),
      {"fluid.spacing=0.02", "fluid.artificial_viscosity=0.01", "solver.shifting=\"fickian\""});
  EXPECT_EQ(cost_settings(viscous),
            (std::vector<std::string>{"shifting_fickian", "artificial_viscosity"}));
  EXPECT_NEAR(estimate_cost(d, viscous, p).step_s, 1.25 * 1.5 * step, 1e-12);
  EXPECT_TRUE(
      cost_settings(load_scene(scene_path("dambreak.toml"), {"fluid.artificial_viscosity=0"}))
          .empty());
  // A wider support meets (support / 2)^3 as many pairs: the fluid's term scales.
  const Scene wide =
      load_scene(scene_path("dambreak.toml"), {"fluid.spacing=0.02", "fluid.support=2.5"});
  const PlanReport pw = Simulation::plan(wide);
  EXPECT_NEAR(estimate_cost(d, wide, pw).step_s,
              1e-4 + std::pow(1.25, 3) * 1e-8 * double(pw.fluid) + 1e-9 * double(pw.boundary),
              1e-12);
  // A device's own exponent of the pairs, and a step's cost that scales with them alone.
  const std::vector<DeviceCost> table =
      parse_cost_model("[gpu]\nstart_s = 2\nstep_s = 1e-4\nfluid_s = 1e-8\nboundary_s = 1e-9\n"
                       "pair_step_s = 5e-5\npairs_exponent = 1.5\n",
                       "test");
  ASSERT_EQ(table.size(), 1u);
  EXPECT_TRUE(table[0].factors.empty()) << "pairs_exponent is no setting's factor";
  EXPECT_NEAR(estimate_cost(table[0], wide, pw).step_s,
              1e-4 + std::pow(1.25, 1.5) * (5e-5 + 1e-8 * double(pw.fluid)) +
                  1e-9 * double(pw.boundary),
              1e-12);
  EXPECT_EQ(fluid_device(1).pairs_exponent, 3.0) << "a table without it: the pairs' count";
}

TEST(CostModel, AnEstimateAddsTheKnitsTermsItsStagesCallFor) {
  DeviceCost d = fluid_device(1);
  d.knit_substep_s = 2e-5;
  d.knit_s = 3e-9;
  d.self_contact_s = 5e-10;
  d.coupling_s = 7e-9;
  d.conserving_s = 1.1e-9;
  // The drape: a knit alone, self-collision on: no fluid part, its substeps' terms.
  const Scene drape =
      load_scene(scene_path("drape.toml"), {"knit.piece.0.wales=16", "knit.piece.0.courses=16"});
  EXPECT_EQ(knit_cost_terms(drape), (std::vector<std::string>{"knit_self_contact"}));
  const PlanReport pd = Simulation::plan(drape);
  ASSERT_EQ(pd.fluid, 0u);
  const double nd = double(pd.knit);
  EXPECT_NEAR(estimate_cost(d, drape, pd).step_s, 1 * (2e-5 + nd * (3e-9 + 5e-10)), 1e-15);
  // The pour: the fluid's part, and 4 substeps of the knit with its coupling; the conserving
  // model adds its transfers once a step; without self-collision its term goes.
  const Scene pour =
      load_scene(scene_path("pour.toml"), {"knit.piece.0.wales=16", "knit.piece.0.courses=16",
                                           "fluid.spacing=0.02", "solver.neighbour_list=\"off\""});
  EXPECT_EQ(knit_cost_terms(pour),
            (std::vector<std::string>{"knit_self_contact", "knit_coupling"}));
  const PlanReport pp = Simulation::plan(pour);
  const double fluid = 1e-4 + 1e-8 * double(pp.fluid) + 1e-9 * double(pp.boundary);
  const double np = double(pp.knit);
  ASSERT_EQ(pour.knit.substeps, 4);
  EXPECT_NEAR(estimate_cost(d, pour, pp).step_s, fluid + 4 * (2e-5 + np * (3e-9 + 5e-10 + 7e-9)),
              1e-15);
  // The coupling's fixed cost, once a step.
  DeviceCost fixed = d;
  fixed.coupling_step_s = 3e-4;
  EXPECT_NEAR(estimate_cost(fixed, pour, pp).step_s - estimate_cost(d, pour, pp).step_s, 3e-4,
              1e-15);
  const Scene kept = load_scene(scene_path("pour.toml"),
                                {"knit.piece.0.wales=16", "knit.piece.0.courses=16",
                                 "fluid.spacing=0.02", "solver.neighbour_list=\"off\"",
                                 "capillary.model=\"conserving\"", "knit.self_collision=false"});
  EXPECT_EQ(knit_cost_terms(kept),
            (std::vector<std::string>{"knit_coupling", "absorption_conserving"}));
  // (its Darcy substeps a step from the plan of the conserving scene)
  const PlanReport pk = Simulation::plan(kept);
  ASSERT_GE(pk.darcy_substeps, 1);
  EXPECT_NEAR(estimate_cost(d, kept, pk).step_s,
              1e-4 + 1e-8 * double(pk.fluid) + 1e-9 * double(pk.boundary) +
                  4 * (2e-5 + np * (3e-9 + 7e-9)) + 1.1e-9 * np * pk.darcy_substeps,
              1e-15);
  // The knit's fixed costs: a step's wherever there is a knit (the drape too), a run's once;
  // the conserving absorption's a Darcy substep only where it runs.
  DeviceCost knit_fixed = d;
  knit_fixed.knit_step_s = 2.5e-5;
  knit_fixed.knit_start_s = 0.4;
  knit_fixed.conserving_substep_s = 3e-4;
  for (const auto& [scene, plan, conserving] :
       {std::tuple{&drape, &pd, false}, std::tuple{&pour, &pp, false},
        std::tuple{&kept, &pk, true}}) {
    const CostEstimate a = estimate_cost(d, *scene, *plan),
                       b = estimate_cost(knit_fixed, *scene, *plan);
    const double step = 2.5e-5 + (conserving ? 3e-4 * plan->darcy_substeps : 0.0);
    EXPECT_NEAR(b.step_s - a.step_s, step, 1e-15);
    EXPECT_NEAR(b.total_s - a.total_s, 0.4 + plan->run_steps * step, 1e-9);
  }
  // A run without a knit pays none of them.
  const Scene tank = load_scene(scene_path("hydrostatic.toml"));
  const PlanReport pt = Simulation::plan(tank);
  ASSERT_EQ(pt.knit, 0u);
  EXPECT_EQ(estimate_cost(knit_fixed, tank, pt).total_s, estimate_cost(d, tank, pt).total_s);
  // The snapshots: a particle's cost a frame, the frames the plan counts (1.5 s every 0.02 s
  // and the start: 76).
  DeviceCost out = d;
  out.output_s = 1e-7;
  EXPECT_EQ(pp.output_frames, 76);
  EXPECT_NEAR(estimate_cost(out, pour, pp).total_s - estimate_cost(d, pour, pp).total_s,
              76 * 1e-7 * double(pp.fluid + pp.boundary + pp.knit), 1e-9);
  // A device without knit terms counts only the fluid.
  DeviceCost fluid_only = d;
  fluid_only.knit_substep_s = fluid_only.knit_s = 0;
  fluid_only.self_contact_s = fluid_only.coupling_s = fluid_only.conserving_s = 0;
  EXPECT_FALSE(fluid_only.has_knit_terms());
  EXPECT_NEAR(estimate_cost(fluid_only, pour, pp).step_s, fluid, 1e-15);
}

// A preview is for a quick look: it never plans more steps than the scene as written. Where the
// knit-fluid contact limits the step (the pour, the wicking strip), the preview's particles,
// 8 times heavier, took a contact ~3.6 times stiffer by the default rule and halved the knit's
// substep (the pour: 51,683 steps against 27,148); the preset keeps the scene's stiffness.
TEST(CostModel, APreviewPlansNoMoreStepsThanTheSceneAsWritten) {
  int coupled = 0;
  for (const auto& e : std::filesystem::directory_iterator(test::source_dir() / "scenes")) {
    if (e.path().extension() != ".toml")
      continue;
    const Scene own = load_scene(e.path().string());
    const Scene preview = load_scene(e.path().string(), {"solver.quality=\"preview\""});
    const PlanReport po = Simulation::plan(own), pp = Simulation::plan(preview);
    SCOPED_TRACE(e.path().filename().string());
    EXPECT_LE(pp.run_steps, po.run_steps);
    EXPECT_GE(pp.initial_dt, po.initial_dt);
    if (!own.has(Module::Contact) || !own.has(Module::Fluid))
      continue;
    ++coupled;
    EXPECT_DOUBLE_EQ(pp.coupling_stiffness, po.coupling_stiffness);
    // The default rule at the preview's own spacing: the step the preset avoids.
    Scene stiff = preview;
    stiff.coupling.stiffness_spacing = 0;
    const PlanReport ps = Simulation::plan(stiff);
    // The particle 8 times heavier, the reach at most twice as long (R_f = dp / 2 doubles,
    // R_k does not grow): at least twice as stiff (the pour 3.6 times, the strip 2.7).
    EXPECT_GE(ps.coupling_stiffness, 2 * po.coupling_stiffness);
    EXPECT_GT(ps.run_steps, po.run_steps);
  }
  EXPECT_EQ(coupled, 2); // the pour and the wicking strip
}
