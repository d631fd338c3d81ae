// The paper's pouring scene (Fig. 7, scenes/pour.toml: 64,000 fluid particles poured onto
// 49,923 knit points over a sphere), 5,000 steps on the GPU (2,000 coarser on the CPU): nothing
// becomes NaN, no fluid particle ends inside the sphere or the floor, no knit point either, the
// knit's saturation stays within [0, s_max], and the fluid reaches and wets the knit. s_max = 1.1 /
// phi: the fluid density the kernel sees at a knit point cannot pass the fluid's own density (10%
// allowed for its compression), and s = rho~ / (phi rho0) (Eq. 9).
#include "domain/Scene.hpp"
#include "domain/Simulation.hpp"
#include "kernels/exec/Backend.hpp"
#include "support/TestPaths.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

using namespace kf;

namespace {

/// What a run held: the backend's peak (the run's own, past what was held before it) and the
/// most fluid particles near the knit at a build of the coupling's lists.
struct PourHeld {
  double peak = 0;
  std::uint64_t most_rows = 0;
};

void run_pour(const Scene& s, exec::Backend backend, int steps, PourHeld* out = nullptr) {
  const std::size_t before = exec::held_bytes(backend).now;
  exec::reset_peak_bytes(backend);
  auto sim = Simulation::create(s, backend);
  PourHeld held;
  const Diagnostics d0 = sim->diagnostics();
  const double s_max = 1.1 / s.capillary.porosity;
  double fluid_closest = 1e30, knit_closest = 1e30, s_high = 0, absorbed = 0;
  std::uint64_t contacts = 0, wet = 0;
  const int every = 250;
  for (int step = 1; step <= steps; ++step) {
    sim->step(s.end_time);
    if (step % every != 0)
      continue;
    const Diagnostics d = sim->diagnostics();
    ASSERT_TRUE(std::isfinite(d.kinetic_energy) && std::isfinite(d.knit_kinetic_energy) &&
                std::isfinite(d.max_saturation))
        << "step " << step;
    fluid_closest = std::min(fluid_closest, d.min_rigid_distance);
    knit_closest = std::min(knit_closest, d.knit_min_rigid_distance);
    s_high = std::max(s_high, d.max_saturation);
    contacts = std::max(contacts, d.coupling_contacts);
    wet = std::max(wet, d.wet_points);
    held.most_rows = std::max(held.most_rows, d.coupling_rows);
    absorbed = std::max(absorbed, d.absorbed_mass);
    const io::Frame fr = sim->frame();
    const auto sat = fr.find("knit")->find("saturation")->as<float>(); // the scene is float
    for (float q : sat)
      ASSERT_TRUE(q >= 0 && q <= s_max) << "saturation " << q << " at step " << step;
  }
  const Diagnostics d = sim->diagnostics();
  std::printf("pour (%zu fluid, %zu knit): %d steps to t = %.4f s; fluid closest to a solid %.3g "
              "m, knit %.3g m; up to "
              "%llu fluid-knit contacts, %llu wet knit points, absorbed up to %.3g kg; max "
              "saturation %.3f (bound %.3f); fluid max speed %.3g m/s, density error max %.2f%%\n",
              d0.fluid, d0.knit, steps, sim->time(), fluid_closest, knit_closest,
              static_cast<unsigned long long>(contacts), static_cast<unsigned long long>(wet),
              absorbed, s_high, s_max, d.max_speed, 100 * d.max_density_error);
  EXPECT_GE(fluid_closest, 0.0) << "a fluid particle inside a solid";
  EXPECT_GE(knit_closest, 0.0) << "a knit point inside a solid";
  EXPECT_GT(contacts, 100u) << "the pour never reached the knit";
  EXPECT_GT(wet, 100u) << "the knit never got wet";
  held.peak = double(exec::held_bytes(backend).peak - before);
  if (out)
    *out = held;
}

Scene pour_scene() {
  return load_scene((test::source_dir() / "scenes" / "pour.toml").string(),
                    {"output.enabled=false"});
}

} // namespace

// The scene at its default resolution, the paper's scale: on the GPU (a 2-core CPU takes most
// of an hour for 5,000 steps; the reduced run below covers the CPU in CI).
TEST(Pour, FiveThousandStepsAtThePapersScaleOnTheGpu) {
  if (!exec::cuda_available())
    GTEST_SKIP() << "no CUDA device";
  const Scene s = pour_scene();
  ASSERT_EQ(Simulation::plan(s).fluid, 64000u) << "the paper's scale";
  ASSERT_GT(Simulation::plan(s).knit, 45000u) << "the paper's scale";
  run_pour(s, exec::Backend::Cuda, 5000);
}

// The same scene coarser (fluid spacing 1 cm: 8,000 particles; 48 x 48 stitches: 7,203 knit
// points), 2,000 steps on the CPU: to t = 0.26 s, the fluid on the knit from ~0.1 s (a fifth of
// the time the half-resolution knit's 5,000 steps took on CI's 2 cores).
TEST(Pour, TwoThousandStepsCoarserOnTheCpu) {
  Scene s = pour_scene();
  s.fluid.spacing *= 2;
  s.knit.pieces[0].wales = 48;
  s.knit.pieces[0].courses = 48;
  PourHeld held;
  run_pour(s, exec::Backend::Cpu, 2000, &held);
  // `knitflow plan`'s memory against the run's peak: an upper figure (a GPU chosen by it is
  // not short), as near as its bound on the fluid near the knit allows. Here the bound is the
  // whole fluid (the knit's cells and those around hold more at its spacing) where at most 29%
  // came near: plan 8.8% over the peak (measured; the rows' columns for the whole fluid, 8,000
  // rows where 2,334 were used). It was 2.2% over while the coupling's pair forces grew by a copy
  // (old and new held at once at the peak, 2.8 MB); before it counted the coupling, 53% of it.
  const PlanReport plan = Simulation::plan(s);
  std::printf("the coarse pour: the CPU backend's peak %.0f bytes, plan %.4f of it; the coupling's "
              "rows up to %llu fluid particles, plan's bound %zu\n",
              held.peak, double(plan.bytes()) / held.peak,
              static_cast<unsigned long long>(held.most_rows), plan.coupling_near);
  EXPECT_LE(held.most_rows, plan.coupling_near);
  EXPECT_GE(double(plan.bytes()), held.peak);
  EXPECT_LE(double(plan.bytes()), 1.10 * held.peak);
}

// The run's own sum of what it holds (Simulation::memory_bytes, the summary's and plan's measure)
// is what the CPU backend's ledger holds for it (every buffer it allocated, exec::held_bytes),
// after its first step: the coupling's lists built, a row a fluid particle near the knit.
TEST(Pour, TheMemoryCountedIsWhatTheRunHolds) {
  Scene s = pour_scene();
  s.fluid.spacing *= 2;
  s.knit.pieces[0].wales = 48;
  s.knit.pieces[0].courses = 48;
  const std::size_t before = exec::held_bytes(exec::Backend::Cpu).now;
  auto sim = Simulation::create(s, exec::Backend::Cpu);
  sim->step(1e9);
  const double held = double(exec::held_bytes(exec::Backend::Cpu).now - before);
  const double counted = double(sim->memory_bytes());
  std::printf("the coarse pour after a step: the ledger %.0f bytes, memory_bytes %+.0f\n", held,
              counted - held);
  // Left out: only buffers of a few words (readings, counters: 220 bytes measured).
  EXPECT_NEAR(counted, held, 1024.0);
}
