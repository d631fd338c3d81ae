// The work the moving solids and handles do, as the watchdog reads it (WatchReading::work;
// domain/Watchdog's energy budget), against what the physics says they must have done: a piston
// raising a column of water (the hydrostatic rise in potential energy), a handle lifting a
// hanging strip (the strip's energy, springs included, where nothing dissipates) and handles
// pushing a strip's points into a pool (the water's energy).
#include "domain/Scene.hpp"
#include "domain/Simulation.hpp"
#include "kernels/boundary/Boundary.hpp"
#include "kernels/exec/DeviceBuffer.hpp"
#include "support/Backends.hpp"
#include "support/KnitScenes.hpp"
#include "support/SceneFactory.hpp"
#include "support/TestPaths.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

using namespace kf;

namespace {

// A strip 4 cm wide and 12 cm tall hanging in its rest shape from its top row, which a handle
// lifts at 0.2 m/s for 0.1 s and then holds; no self-collision: undamped, nothing dissipates.
Scene lifted_strip_scene(double damping_ratio) {
  Scene s = test::falling_strip(0.12, 16, 0.24, false); // the chunky knit's parameters
  s.name = "lift";
  s.domain.min = {-0.2, -0.2, 0};
  s.domain.max = {0.2, 0.2, 0.5};
  s.precision = Precision::Double;
  s.end_time = 0.2;
  KnitPiece& p = s.knit.pieces[0];
  p.center = {0, 0, 0.3}; // hanging straight: z from 0.24 to 0.36
  p.normal = {1, 0, 0};
  p.height = 0.12;
  s.knit.damping_ratio = damping_ratio;
  s.knit.pins.push_back({"top", {-1, -1, 0.355}, {1, 1, 1}, {0, 0, 0.2}, 0.1});
  return s;
}

double knit_energy(const Diagnostics& d) {
  return d.knit_kinetic_energy + d.knit_elastic_energy + d.knit_potential_energy;
}

} // namespace

TEST(MoverWork, PistonDoesTheColumnsRiseInPotentialEnergy) {
  for (const auto b : test::backends()) {
    SCOPED_TRACE(b == exec::Backend::Cuda ? "cuda" : "cpu");
    const Scene scene = test::piston_scene(0.005, 0.3);
    auto sim = Simulation::create(scene, b);
    const WatchReading r0 = sim->watch();
    EXPECT_EQ(r0.work, 0.0);
    while (sim->time() < scene.end_time - 1e-12)
      sim->step(scene.end_time);
    const WatchReading r = sim->watch();
    // The hydrostatic column's potential energy, 1/2 rho g w d^2 L^2 / L', rises by (L' = L -
    // u t = 0.15 m)
    const double rho = 1000, g = 9.81, w = 0.04, d = 0.05, L = 0.18, L1 = 0.15;
    const double rise = 0.5 * rho * g * w * d * d * L * L * (1 / L1 - 1 / L);
    const double gained = r.kinetic + r.potential - r0.kinetic - r0.potential;
    std::printf("piston: work %.6f J, the column's rise %.6f J (hydrostatic), the run's energy "
                "gain %.6f J (kinetic %.6f J at the end)\n",
                r.work, rise, gained, r.kinetic);
    // The work is the rise and the kinetic energy of the sloshing the piston's start set off
    // (7.6% of the rise at the end), less what the viscosity took: measured 0.01% apart (CPU);
    // 0.5% for the viscosity's share and the fluid's compression, which neither side counts.
    EXPECT_NEAR(r.work, rise + r.kinetic, 0.005 * r.work);
    // The run's own energy gain: 4.1% past the work (CPU): the boundary's pressure,
    // extrapolated from the fluid (Adami 2012), is no potential force, so a moving wall gives
    // the fluid a little more than its forces' work; the watchdog's margin (10% by default)
    // covers it. Well below the work, the measure would count work that was not done.
    EXPECT_GE(gained, 0.99 * r.work);
    EXPECT_LE(gained, 1.06 * r.work);
  }
}

TEST(MoverWork, HandleDoesTheLiftedStripsEnergy) {
  for (const auto b : test::backends()) {
    SCOPED_TRACE(b == exec::Backend::Cuda ? "cuda" : "cpu");
    for (const double damping : {0.0, 0.2}) {
      SCOPED_TRACE("damping ratio " + std::to_string(damping));
      const Scene scene = lifted_strip_scene(damping);
      auto sim = Simulation::create(scene, b);
      const double e0 = knit_energy(sim->diagnostics());
      while (sim->time() < scene.end_time - 1e-12)
        sim->step(scene.end_time);
      const WatchReading r = sim->watch();
      const Diagnostics dn = sim->diagnostics();
      const double gained = knit_energy(dn) - e0;
      // The lift at the handle's speed alone: the strip's weight through 2 cm.
      const double lift = r.knit_mass * 9.81 * 0.02;
      std::printf("strip (damping %.1f): work %.6e J, energy gained %.6e J, lift %.6e J\n", damping,
                  r.work, gained, lift);
      EXPECT_GT(r.work, 0.5 * lift) << "the handle did little: the case tests little";
      if (damping == 0) // conservative: all the work stays; measured 0.05% apart (CPU), the
        EXPECT_NEAR(gained, r.work, 0.002 * r.work); // forces' power taken once a substep
      else
        EXPECT_LE(gained, r.work); // the damping takes its share
    }
  }
}

// scenes/wicking.toml's clip and weight lowering a coarse strip (32 x 4 stitches) at 1 m/s, its
// foot 1.5 cm into the pool by 0.025 s, contact only (no capillary suction, whose pull the
// watchdog bounds apart). The weight's points push the water aside: the water's energy comes
// from the handles, which hold their points against the fluid's push. Before the handles' work
// counted that push it measured 1.26e-3 J where the run gained 8.4e-3 J (the scene with summation
// density and its capillary: the watchdog stopped the wicking study's run at 32 stitches there).
TEST(MoverWork, HandlesPushingTheirPointsIntoWaterDoTheWatersEnergy) {
  Scene scene = load_scene((test::source_dir() / "scenes" / "wicking.toml").string(),
                           {"output.enabled=false", "knit.piece.0.courses=32",
                            "knit.piece.0.wales=4", "simulation.end_time=0.025"});
  std::erase(scene.modules, Module::Capillary);
  ASSERT_TRUE(scene.has(Module::Contact));
  for (const auto b : test::backends()) {
    SCOPED_TRACE(b == exec::Backend::Cuda ? "cuda" : "cpu");
    auto sim = Simulation::create(scene, b);
    const WatchReading r0 = sim->watch();
    const double e0 = r0.kinetic + r0.potential + sim->diagnostics().knit_elastic_energy;
    while (sim->time() < scene.end_time - 1e-12)
      sim->step(scene.end_time);
    const WatchReading r = sim->watch();
    const double gained = r.kinetic + r.potential + sim->diagnostics().knit_elastic_energy - e0;
    std::printf("strip lowered into water: work %.6e J, energy gained %.6e J\n", r.work, gained);
    // Measured: the gain 72% of the work (CPU); the rest went into the contact's damping, the
    // viscosity and the water's compression, which neither side counts. More than the work: an
    // energy source the budget misses; under 0.6 of it, work counted that was not done.
    EXPECT_LE(gained, r.work);
    EXPECT_GE(gained, 0.6 * r.work);
  }
}

// A moving box's contact corrections: the fixed-point sum against each point's change of kinetic
// and gravitational energy summed on the host (2,000 random points, some inside the box); within
// half a unit a correction (the rounding to the unit). A box at rest measures nothing.
TEST(MoverWork, ContactCorrectionsByAMovingSolidAddTheirEnergyChange) {
  for (const auto b : test::backends()) {
    SCOPED_TRACE(b == exec::Backend::Cuda ? "cuda" : "cpu");
    for (const bool moving : {true, false}) {
      std::mt19937 rng(7);
      std::uniform_real_distribution<double> pos(-0.2, 0.2), vel(-1.0, 1.0), mass(0.5, 2.0);
      const std::size_t n = 2000;
      std::vector<Vec3d> x(n), v(n);
      std::vector<double> m(n);
      for (std::size_t i = 0; i < n; ++i) {
        x[i] = {pos(rng), pos(rng), pos(rng)};
        v[i] = {vel(rng), vel(rng), vel(rng)};
        m[i] = mass(rng);
      }
      RigidShape<double> box;
      box.kind = ShapeKind::Box;
      box.a = {-0.1, -0.1, -0.1};
      box.b = {0.1, 0.1, 0.1};
      box.velocity = moving ? Vec3d{0.3, 0, -0.5} : Vec3d{0, 0, 0};
      box.offset = box.velocity * 0.1;
      exec::DeviceBuffer<Vec3d> xd(b, 0, "x"), vd(b, 0, "v");
      exec::DeviceBuffer<double> md(b, 0, "m");
      exec::DeviceBuffer<RigidShape<double>> shape(b, 0, "shape");
      exec::DeviceBuffer<std::uint64_t> count(b, 0, "count"), sum(b, 0, "sum");
      xd.assign(x);
      vd.assign(v);
      md.assign(m);
      shape.assign(std::vector<RigidShape<double>>{box});
      count.assign(std::vector<std::uint64_t>{0});
      sum.assign(std::vector<std::uint64_t>{0});
      const Vec3d g{0, 0, -9.81};
      const double unit = std::ldexp(1.0, -40);
      enforce_rigid_shapes(exec::Exec{b}, xd.data(), vd.data(), n, shape.data(), 1, 0.001, 0.3,
                           nullptr, count.data(), "test", {md.data(), g, unit, sum.data()});
      const auto x1 = xd.to_host(), v1 = vd.to_host();
      double expected = 0;
      for (std::size_t i = 0; i < n; ++i)
        expected += 0.5 * m[i] * (norm2(v1[i]) - norm2(v[i])) - m[i] * dot(g, x1[i] - x[i]);
      const std::uint64_t corrected = count.to_host()[0];
      ASSERT_GT(corrected, 100u) << "few points met the box: the case tests little";
      const double measured = double(static_cast<std::int64_t>(sum.to_host()[0])) * unit;
      if (moving) {
        EXPECT_NEAR(measured, expected,
                    0.5 * unit * double(corrected) + 1e-12 * std::abs(expected));
        EXPECT_NE(expected, 0.0);
      } else {
        EXPECT_EQ(measured, 0.0);
      }
    }
  }
}
