// A tank of water at rest, with summation density (two kernels) and with the continuity
// equation (which starts from rest density everywhere and must find the same equilibrium).
// After settling (slices averaged over the last 0.2 s):
// - the density follows the column's compression rho0 + rho0 g (z0 - z) / c^2 in the bulk
//   (deeper than one support radius below the surface: there the kernel is cut off and particles
//   are under-dense by construction), slice by slice and particle by particle;
// - the pressure profile within a per-case bound (of the bottom pressure rho0 g H) of
//   rho0 g depth, where depth is measured from the free surface z0 = where the bulk pressure
//   extrapolates to zero;
// - the bulk pressure gradient within 2% of rho0 g, and the bottom pressure within 1.5% of
//   M g / A (force balance, independent of particle arrangement);
// - z0 within one particle spacing of H = M / (rho0 A), the height the mass fills at rest density.
#include "domain/Simulation.hpp"
#include "support/SceneFactory.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <vector>

using namespace kf;

struct KernelCase {
  KernelType kernel;
  double support; // in particle spacings
  DensityModel density = DensityModel::Summation;
  // Initial positions moved by up to this many spacings (a fixed pseudo-random pattern): the
  // equilibrium must not hang on one rounding pattern of the start.
  double jitter = 0;
  // Bounds at what each case reaches (measured, in the comment at the instantiation):
  double profile = 0;      // pressure profile error, of rho0 g H
  double particle_rho = 0; // largest particle density error against the compressed column
  double width = 0.15;     // the tank's square footprint [m]
};

class Hydrostatic : public ::testing::TestWithParam<KernelCase> {};

// The paper's spiky kernel is not among these: at 2 dp its discrete gradient is 0.77 of the true
// one and the profile misses by ~8% even at 3 dp (docs/VALIDATION.md); the study quantifies it.
// Measured (slices averaged over the last 0.2 s), in order: profile error 2.12%, 0.55%, 0.92%;
// particle density against the compressed column 0.165%, 0.060%, 0.026% (summation's lattice
// error is per particle; continuity starts every particle at rho0 and keeps its own). Bounds
// about 1.4x those. The Wendland tank (3 dp: 3.4x the cubic's neighbours) and the continuity
// tank are 0.10 m wide, not 0.15: the same 0.25 m column, the walls nearer, for CI's 40
// minutes (0.15 m wide they measured 0.93-1.01% / 0.099% and 1.09% / 0.007%, in 130 and 56 s;
// 0.10 m: 64 and 28 s on one core; the Wendland tank 0.55% on 1 and 2 threads). The summation
// tank stays 0.15 m wide: 0.10 m put its floor pressure +1.44% over M g / A, at the edge of the
// 1.5% bound below. The Wendland tank starts moved by 1e-3 dp (a fixed pattern): unmoved it
// lands within 0.14% of the same profile error (measured at 0.15 m; it ran here as a fourth
// case until the CI budget asked for its 3 minutes; test_stress's wendland_tank settles another
// perturbed start).
INSTANTIATE_TEST_SUITE_P(
    Kernels, Hydrostatic,
    ::testing::Values(
        KernelCase{KernelType::CubicSpline, 2.0, DensityModel::Summation, 0, 0.03, 0.0025},
        KernelCase{KernelType::WendlandC2, 3.0, DensityModel::Summation, 1e-3, 0.008, 0.0009, 0.10},
        KernelCase{KernelType::CubicSpline, 2.0, DensityModel::Continuity, 0, 0.013, 0.00037,
                   0.10}));

TEST_P(Hydrostatic, TankSettlesToHydrostaticPressure) {
  const double width = GetParam().width;
  Scene s = test::tank_scene({width, width, 0.35}, {width, width, 0.25}, 0.01);
  s.fluid.eos = EosType::Linear; // the paper's EOS
  s.fluid.speed_of_sound = 20;   // hydrostatic compression g H / c^2 = 0.6%
  s.fluid.viscosity = 0.05;
  // Settle: viscosity hardly damps the column's compression mode (wavelength 4H), so damp all
  // velocities for 0.6 s, then let it run free for 0.4 s: what remains is the equilibrium.
  s.solver.damping = 30;
  s.solver.damping_until = 0.6;
  s.solver.kernel = GetParam().kernel;
  s.fluid.support = GetParam().support;
  s.solver.density = GetParam().density;
  auto sim = Simulation::create(s, exec::Backend::Cpu);
  if (GetParam().jitter > 0) {
    io::Frame start = sim->frame();
    for (auto& phase : start.phases)
      if (phase.name == "fluid")
        for (auto& field : phase.fields)
          if (field.name == "position") {
            auto x = field.as<float>();
            std::uint32_t state = 12345;
            for (float& xi : x) {
              state = state * 1664525u + 1013904223u; // LCG: the same pattern every run
              xi += float(GetParam().jitter * s.fluid.spacing * (state / 4294967296.0 - 0.5));
            }
            field = io::Field::from("position", x, 3);
          }
    sim->restore(start);
  }
  // What remains after the damping rings faintly; a snapshot at one instant catches that ringing
  // at whatever phase the run's rounding gives it (the Wendland case's profile error moved from
  // 1.2% to 4.4% under a regrouping of products, docs/VALIDATION.md). The slices are therefore
  // averaged over nine snapshots across the last 0.2 s, the equilibrium's estimate.
  while (sim->time() < 0.8 - 1e-12)
    sim->step(0.8);
  const double rho0 = s.fluid.rest_density, g = 9.81, dp = s.fluid.spacing, h = s.support_radius();
  const int slices = static_cast<int>(0.35 / dp);
  std::vector<double> psum(slices, 0), zsum(slices, 0), rsum(slices, 0), cnt(slices, 0);
  for (int sample = 0; sample < 9; ++sample) {
    const double t = 0.8 + 0.025 * sample;
    while (sim->time() < t - 1e-12)
      sim->step(t);
    const io::Frame fr = sim->frame();
    const io::Phase& f = *fr.find("fluid");
    const auto x = f.find("position")->as<float>(), rho = f.find("density")->as<float>(),
               p = f.find("pressure")->as<float>();
    // Slices one spacing thick: mean height, pressure and density.
    for (std::size_t i = 0; i < rho.size(); ++i) {
      const int k = std::min(slices - 1, std::max(0, static_cast<int>(x[3 * i + 2] / dp)));
      psum[k] += p[i];
      zsum[k] += x[3 * i + 2];
      rsum[k] += rho[i];
      cnt[k] += 1;
    }
  }
  {
    // Settled: rms speed small against the free-fall speed sqrt(g H) = 1.6 m/s.
    const Diagnostics d = sim->diagnostics();
    const double total_mass = 1000.0 * width * width * 0.25;
    const double v_rms = std::sqrt(2 * d.kinetic_energy / total_mass);
    std::printf("after settling: rms speed %.4f m/s, max %.4f m/s\n", v_rms, d.max_speed);
    ASSERT_LT(v_rms, 0.03) << "not settled";
  }

  const io::Frame fr = sim->frame();
  const io::Phase& f = *fr.find("fluid");
  const auto x = f.find("position")->as<float>(), rho = f.find("density")->as<float>(),
             m = f.find("mass")->as<float>();
  const std::size_t n = rho.size();
  double mass = 0;
  for (float mi : m)
    mass += mi;
  const double area = width * width;
  const double H = mass / (rho0 * area);

  // Least-squares line through the bulk slices (below H - 2h, above the first layer).
  double sz = 0, sp = 0, szz = 0, szp = 0, ns = 0;
  std::vector<std::pair<double, double>> bulk;
  for (int k = 1; k < slices; ++k) {
    if (!cnt[k])
      continue;
    const double z = zsum[k] / cnt[k], pm = psum[k] / cnt[k];
    if (z > H - 2 * h)
      continue;
    bulk.push_back({z, pm});
    sz += z, sp += pm, szz += z * z, szp += z * pm, ns += 1;
  }
  ASSERT_GE(ns, 10);
  const double slope = (ns * szp - sz * sp) / (ns * szz - sz * sz);
  const double intercept = (sp - slope * sz) / ns;
  const double z0 = -intercept / slope;
  const double pbottom_expected = mass * g / area;
  const double p0 = psum[0] / cnt[0];
  double max_profile_err = 0, max_bulk_rho_err = 0, max_compressed_err = 0, mean_compressed_err = 0;
  std::size_t n_bulk = 0;
  const double c2 = s.fluid.speed_of_sound * s.fluid.speed_of_sound;
  for (const auto& [z, pm] : bulk)
    max_profile_err =
        std::max(max_profile_err, std::fabs(pm - rho0 * g * (z0 - z)) / (rho0 * g * H));
  for (std::size_t i = 0; i < n; ++i)
    if (x[3 * i + 2] < z0 - h) {
      max_bulk_rho_err =
          std::max(max_bulk_rho_err, std::fabs(rho[i] - rho0) / rho0); // printed only
      // The linear EOS compresses the column: rho = rho0 + rho0 g (z0 - z) / c^2 (0.61% at the
      // floor), so the density is judged against that, not against rho0.
      const double ref = rho0 + rho0 * g * (z0 - x[3 * i + 2]) / c2;
      const double e = std::fabs(rho[i] - ref) / rho0;
      max_compressed_err = std::max(max_compressed_err, e);
      mean_compressed_err += e;
      ++n_bulk;
    }
  mean_compressed_err /= std::max<std::size_t>(1, n_bulk);
  // The slices' mean density against the compressed column (what a solver without compression,
  // rho = rho0 throughout, misses by up to 0.6% at the floor).
  double max_slice_rho_err = 0;
  for (int k = 1; k < slices; ++k)
    if (cnt[k] && zsum[k] / cnt[k] < z0 - h) {
      const double ref = rho0 + rho0 * g * (z0 - zsum[k] / cnt[k]) / c2;
      max_slice_rho_err = std::max(max_slice_rho_err, std::fabs(rsum[k] / cnt[k] - ref) / rho0);
    }
  // Bottom layer: extrapolate its pressure to the floor (z = 0) along the measured gradient.
  const double p_floor = p0 - slope * (zsum[0] / cnt[0]);
  std::printf(
      "hydrostatic: gradient %.1f Pa/m (rho0 g = %.1f), surface z0 = %.4f m (H = %.4f m), "
      "floor pressure %.1f Pa (M g / A = %.1f), profile error %.2f%%, bulk density error %.3f%% "
      "(against the compressed column: max %.3f%%, mean %.4f%%, slices %.4f%%)\n",
      -slope, rho0 * g, z0, H, p_floor, pbottom_expected, 100 * max_profile_err,
      100 * max_bulk_rho_err, 100 * max_compressed_err, 100 * mean_compressed_err,
      100 * max_slice_rho_err);
  // Gradient measured +0.44% to +1.35% of rho0 g, floor pressure +0.04% to +0.9% of M g / A.
  EXPECT_NEAR(-slope, rho0 * g, 0.02 * rho0 * g);
  EXPECT_NEAR(p_floor, pbottom_expected, 0.015 * pbottom_expected);
  EXPECT_LT(max_profile_err, GetParam().profile);
  // The column's compression, 0.61% at the floor, must be there: the slices' mean density
  // follows rho0 + rho0 g (z0 - z) / c^2 within 0.013% at worst (measured), bound 0.03%; a
  // solver that kept rho0 everywhere misses it by ~0.5% (the old bound, 1% against rho0, passed
  // it).
  EXPECT_LT(max_slice_rho_err, 3e-4);
  EXPECT_LT(max_compressed_err, GetParam().particle_rho);
  EXPECT_NEAR(z0, H, dp);
  EXPECT_EQ(sim->diagnostics().guard_corrections, 0u)
      << "the wall forces alone must hold the fluid";
}

// fluid.initial_density = "hydrostatic" (continuity): the tank starts at the EOS density of the
// weight above each particle, P = rho0 g (H - z) with the surface at the block's top, and so
// starts near equilibrium: over its first 0.1 s, undamped, it moves far less than the same tank
// started at rest density (which first sinks by its hydrostatic compression and rings).
TEST(HydrostaticStart, ContinuityTankStartsNearEquilibrium) {
  auto tank = [](Scene::Fluid::InitialDensity start) {
    Scene s = test::tank_scene({0.15, 0.15, 0.35}, {0.15, 0.15, 0.25}, 0.01);
    s.fluid.eos = EosType::Linear;
    s.fluid.speed_of_sound = 20;
    s.fluid.viscosity = 0.05;
    s.solver.kernel = KernelType::CubicSpline;
    s.solver.density = DensityModel::Continuity;
    s.fluid.initial_density = start;
    return s;
  };
  const Scene s = tank(Scene::Fluid::InitialDensity::Hydrostatic);
  auto sim = Simulation::create(s, exec::Backend::Cpu);
  {
    const io::Frame fr = sim->frame();
    const io::Phase& f = *fr.find("fluid");
    const auto x = f.find("position")->as<float>(), rho = f.find("density")->as<float>();
    const double rho0 = s.fluid.rest_density, c2 = 20.0 * 20.0, g = 9.81;
    double worst = 0;
    for (std::size_t i = 0; i < rho.size(); ++i) {
      const double expected = rho0 + rho0 * g * (0.25 - x[3 * i + 2]) / c2; // linear EOS
      worst = std::max(worst, std::fabs(rho[i] - expected) / rho0);
    }
    std::printf("hydrostatic start: largest density error %.2e rho0 at t = 0\n", worst);
    EXPECT_LT(worst, 1e-6);
  }
  auto rms_over = [](Simulation& run, double t_end) {
    double worst = 0;
    for (double t = 0.01; t < t_end + 1e-9; t += 0.01) {
      while (run.time() < t - 1e-12)
        run.step(t);
      const Diagnostics d = run.diagnostics();
      worst = std::max(worst, std::sqrt(2 * d.kinetic_energy / (1000.0 * 0.15 * 0.15 * 0.25)));
    }
    return worst;
  };
  const double hydrostatic = rms_over(*sim, 0.1);
  auto rest_run = Simulation::create(tank(Scene::Fluid::InitialDensity::Rest), exec::Backend::Cpu);
  const double rest = rms_over(*rest_run, 0.1);
  std::printf("largest rms speed over 0.1 s: %.2e m/s from hydrostatic density, %.2e from rest "
              "density\n",
              hydrostatic, rest);
  EXPECT_LT(hydrostatic, 0.3 * rest);
}
