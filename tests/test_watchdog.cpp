// The watchdog (P8): its reading against a brute-force sum over a frame on both backends, its
// limits against their definitions, and through the app: a run going wrong stops with a report
// naming the measure, its value and its limit, the worst particle and its neighbourhood, and a
// diagnostic snapshot that opens; with on_instability = "rollback" it goes back to its last
// checkpoint with smaller steps, and without a checkpoint to go back to it stops as "stop" does.
#include "core/Error.hpp"
#include "domain/Watchdog.hpp"
#include "io/SnapshotReader.hpp"
#include "support/Backends.hpp"
#include "support/RunKnitflow.hpp"
#include "support/TestPaths.hpp"
#include "support/WatchSums.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <regex>
#include <string>

namespace fs = std::filesystem;
using namespace kf;

namespace {

using test::run_knitflow;

const std::string kDamBreak = " --device cpu -q --set fluid.spacing=0.02 "
                              "--set simulation.end_time=0.3 --set output.interval=0.05 ";

std::string scene(const char* name) {
  return (test::source_dir() / "scenes" / name).string();
}

} // namespace

// A fluid whose speed of sound (2 m/s) its own fall outruns (~2.4 m/s at 0.3 m): the watchdog's
// default limit, the speed of sound, trips (the density bound raised: so soft a fluid also
// compresses past 30%, which trips first at the default); the report names the speed and the
// key; the diagnostic snapshot it names opens.
TEST(Watchdog, StopsWithAReportAndADiagnosticSnapshot) {
  const auto cwd = test::scratch_dir("watchdog_stop");
  const auto r = run_knitflow("run " + scene("dambreak.toml") + kDamBreak +
                                  "--set fluid.speed_of_sound=2 "
                                  "--set solver.watchdog_density_error=10 --output out",
                              cwd);
  EXPECT_EQ(r.code, 1) << r.output;
  EXPECT_NE(r.output.find("watchdog at step "), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("past the watchdog's 2 m/s (solver.watchdog_max_speed"),
            std::string::npos)
      << r.output;
  std::smatch m;
  ASSERT_TRUE(std::regex_search(r.output, m, std::regex(R"(diagnostic snapshot: (\S+\.h5))")))
      << r.output;
  const auto info = io::read_snapshot_info((cwd / m[1].str()).string());
  EXPECT_GT(info.time, 0.0);
  EXPECT_NE(r.output.find("last good snapshot: "), std::string::npos) << r.output;
}

// The same fluid at the default bounds: its density error (past 30%) trips first.
TEST(Watchdog, NamesTheDensityErrorPastItsBound) {
  const auto cwd = test::scratch_dir("watchdog_density");
  const auto r = run_knitflow("run " + scene("dambreak.toml") + kDamBreak +
                                  "--set fluid.speed_of_sound=2 --output out",
                              cwd);
  EXPECT_EQ(r.code, 1) << r.output;
  EXPECT_NE(r.output.find("off rest, past the watchdog's 30% (solver.watchdog_density_error)"),
            std::string::npos)
      << r.output;
}

// An instability after step 150 (KF_FAULT, once): with a checkpoint every 40 steps the run goes
// back to step 120 with cfl and dt_max halved, and finishes.
TEST(Watchdog, RollbackResumesFromTheLastCheckpointWithSmallerSteps) {
  const auto cwd = test::scratch_dir("watchdog_rollback");
  const auto r = run_knitflow("run " + scene("dambreak.toml") + kDamBreak +
                                  "--set 'solver.on_instability=\"rollback\"' "
                                  "--set output.checkpoint_steps=40 --output out",
                              cwd, "KF_FAULT=0:150:instability");
  EXPECT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("injected instability (KF_FAULT) on rank 0 after step 150; diagnostic "
                          "snapshot: out/diagnostic_step_150.h5; rollback 1 of 3 to "
                          "out/checkpoints/checkpoint_000000000120.h5 with cfl 0.1"),
            std::string::npos)
      << r.output;
  EXPECT_TRUE(fs::exists(cwd / "out" / "frame_000006.h5")) << "the run did not finish";
}

// Nothing to go back to (no checkpoint yet): the rollback stops as "stop" does, with the report.
TEST(Watchdog, RollbackWithoutACheckpointStops) {
  const auto cwd = test::scratch_dir("watchdog_no_checkpoint");
  const auto r = run_knitflow("run " + scene("dambreak.toml") + kDamBreak +
                                  "--set 'solver.on_instability=\"rollback\"' "
                                  "--set output.checkpoint_steps=400 --output out",
                              cwd, "KF_FAULT=0:150:instability");
  EXPECT_EQ(r.code, 1) << r.output;
  EXPECT_NE(r.output.find("injected instability (KF_FAULT) on rank 0 after step 150"),
            std::string::npos)
      << r.output;
  EXPECT_EQ(r.output.find("rollback 1"), std::string::npos) << r.output;
}

// The reading (one pass a set on the device) against the frame's rows summed on the host: the
// sums to rounding (1e-12: another order of the same double terms), the maxima exactly (the
// same values compared), the heights from the domain's lowest corner (z = -0.05).
TEST(WatchReading, IsTheBruteForceSumOverTheFrame) {
  for (const auto b : test::backends()) {
    SCOPED_TRACE(b == exec::Backend::Cuda ? "cuda" : "cpu");
    const Scene scene = test::falling_coupled_scene();
    auto sim = Simulation::create(scene, b);
    for (int i = 0; i < 40; ++i)
      sim->step(1.0);
    const WatchReading r = sim->watch();
    const test::FrameSums f = test::frame_sums(sim->frame(), 9.81, -0.05);
    ASSERT_GT(f.fluid_rows, 0u);
    ASSERT_GT(f.knit_rows, 0u);
    EXPECT_GT(f.kinetic, 0.0);
    EXPECT_NEAR(r.mass, f.mass, 1e-12 * f.mass);
    EXPECT_NEAR(r.knit_mass, f.knit_mass, 1e-12 * f.knit_mass);
    EXPECT_NEAR(r.kinetic, f.kinetic, 1e-12 * f.kinetic);
    EXPECT_NEAR(r.potential, f.potential, 1e-12 * f.potential);
    EXPECT_EQ(r.fluid_max_speed, f.fluid_max_speed);
    EXPECT_EQ(r.knit_max_speed, f.knit_max_speed);
    EXPECT_EQ(r.fluid_max_density, f.fluid_max_density);
  }
}

// The limits as defined in domain/Watchdog.hpp, from a reading made up for the purpose: the
// energy's is the start's (elastic included) plus the work done from outside since the start
// (the reading's work less the start's), times 1 + watchdog_energy_rise, plus a hundredth of the
// mass lifted through the domain's height.
TEST(Watchdog, LimitsAreTheScenesAndTripJustPastThem) {
  Scene scene = test::falling_coupled_scene();
  scene.knit.pins.push_back({"lift", {-1, -1, -1}, {1, 1, 1}, {0, 0, 0.5}, 0.2});
  WatchReading start;
  start.mass = 2.0;
  start.kinetic = 0.3;
  start.potential = 1.2;
  start.work = 0.25; // work measured before the watchdog's start: not the budget's
  const double elastic = 0.1, g = 9.81, height = 0.25, u = 0.5;
  const Watchdog dog(scene, start, elastic, 0.0);
  auto limit = [&](double work) {
    return 1.1 * (0.3 + 1.2 + elastic + work - 0.25) + 0.01 * 2.0 * g * height;
  };
  for (double work : {0.25, 0.0, 0.7, 3.0}) {
    WatchReading r = start;
    r.work = work;
    EXPECT_NEAR(dog.energy_limit(r), limit(work), 1e-12) << "work = " << work;
  }
  EXPECT_EQ(dog.fluid_speed_limit(), 10.0); // the speed of sound
  // The knit's: ten times a fall through the domain, twice the handle's and the fluid's start
  // speed, or the fluid's limit where that is higher.
  const double knit_natural = 10 * (std::sqrt(2 * g * height) + 2 * u + 2 * 0.5); // 42.1 m/s
  EXPECT_NEAR(dog.knit_speed_limit(), knit_natural, 1e-12);
  scene.fluid.speed_of_sound = 50;
  EXPECT_EQ(Watchdog(scene, start, elastic, 0.0).knit_speed_limit(), 50.0);
  scene.fluid.speed_of_sound = 10;

  WatchReading r = start;
  r.work = 0.7;
  r.fluid_max_density = 1000.0;
  EXPECT_EQ(dog.check(r).why, "");
  r.kinetic = limit(0.7) - r.potential + 1e-9; // just past
  auto trip = dog.check(r);
  EXPECT_NE(trip.why.find("energy rose"), std::string::npos) << trip.why;
  EXPECT_NE(trip.why.find("solver.watchdog_energy_rise"), std::string::npos) << trip.why;
  // The scene's summation density without the artificial viscosity: the trip names that cause
  // and its cure; with either cure the message is the measure's alone.
  ASSERT_EQ(scene.solver.density, DensityModel::Summation);
  EXPECT_NE(trip.why.find("set fluid.artificial_viscosity = 0.01"), std::string::npos) << trip.why;
  Scene cured = scene;
  cured.fluid.artificial_viscosity = 0.01;
  EXPECT_EQ(Watchdog(cured, start, elastic, 0.0).check(r).why.find("artificial_viscosity"),
            std::string::npos);
  cured = scene;
  cured.solver.density = DensityModel::Continuity;
  EXPECT_EQ(Watchdog(cured, start, elastic, 0.0).check(r).why.find("artificial_viscosity"),
            std::string::npos);
  r.kinetic = limit(0.7) - r.potential - 1e-9; // just short
  EXPECT_EQ(dog.check(r).why, "");

  r.fluid_max_density = 1000.0 * 1.3 * (1 + 1e-9);
  trip = dog.check(r);
  EXPECT_NE(trip.why.find("30% off rest"), std::string::npos) << trip.why;
  EXPECT_EQ(trip.worst, WatchMeasure::FluidDensity);
  r.fluid_max_density = 1000.0;
  r.knit_max_speed = dog.knit_speed_limit() * (1 + 1e-9);
  trip = dog.check(r);
  EXPECT_NE(trip.why.find("a knit point moves at"), std::string::npos) << trip.why;
  EXPECT_EQ(trip.worst, WatchMeasure::KnitSpeed);
  r.knit_max_speed = std::numeric_limits<double>::quiet_NaN();
  trip = dog.check(r);
  EXPECT_EQ(trip.why, "a knit speed is not finite");
}

// A knit blown up by hand (one point's velocity NaN in a restored frame) is named by the step's
// own check: the worst point's id, its neighbourhood, and that the knit's size control found it.
TEST(Watchdog, AnInstabilityNamesTheWorstPointAndItsNeighbourhood) {
  const Scene scene = test::falling_coupled_scene();
  auto sim = Simulation::create(scene, exec::Backend::Cpu);
  sim->step(1.0);
  io::Frame fr = sim->frame();
  io::Phase& knit = *std::find_if(fr.phases.begin(), fr.phases.end(),
                                  [](const io::Phase& p) { return p.name == "knit"; });
  io::Field& v = *std::find_if(knit.fields.begin(), knit.fields.end(),
                               [](const io::Field& f) { return f.name == "velocity"; });
  const auto ids = knit.find("id")->as<std::uint64_t>();
  auto vel = v.as<double>();
  vel[3 * 100] = std::numeric_limits<double>::quiet_NaN();
  v = io::Field::from("velocity", vel, 3);
  sim->restore(fr);
  try {
    sim->step(1.0);
    FAIL() << "a NaN velocity went through a step";
  } catch (const InstabilityError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("a knit velocity or acceleration is not finite"), std::string::npos)
        << what;
    EXPECT_NE(what.find("worst knit point id " + std::to_string(ids[100]) + " at ("),
              std::string::npos)
        << what;
    EXPECT_NE(what.find(" neighbours within "), std::string::npos) << what;
  }
}
