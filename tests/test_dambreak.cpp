// 3D dam break: a water column a wide and 2a high collapses; the surge front Z(T) and the residual
// height at the back wall H(tau) are compared with Martin & Moyce (1952) (tests/data), and no
// particle may leave the tank or enter a wall.
//
// The residual height (the bulk of the collapse) is compared as measured: worst 1.7% (summation)
// and 2.3% (continuity), bound 4% (the digitised curve's scatter is about 2%).
// The front: every instant-release simulation in the literature leads Martin & Moyce's early
// points (Koshizuka & Oka 1996, Colagrossi & Landrini 2003; Lobovsky et al. 2014 measured how the
// gate release delays the front). Ours leads by a nearly constant time offset, not by a growing
// speed error. So the test fits one offset dT by least squares and bounds it: a gate can only
// delay (dT >= 0), and by a fraction of its opening time, which for a release that counts as
// sudden is under 1.25 sqrt(2a / g) = 2.5 in T (Lauber & Hager 1998); measured 0.245 and 0.265
// (13-14 ms in their 57 mm tank), bound 0.3. At T + dT the front agrees within 4.8% and 5.1%
// (bound 6.5%). Unshifted, the worst deviation is 19.0% and 19.4% at T = 1.25; the guard sits
// at 21%. A front 5% too fast (gravity 10% too strong) fails the guard (docs/VALIDATION.md);
// the old 25% let it pass.
#include "domain/Simulation.hpp"
#include "support/SceneFactory.hpp"
#include "support/TestPaths.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <vector>

using namespace kf;

namespace {

std::vector<std::pair<double, double>> read_csv(const std::string& path) {
  std::ifstream in(path);
  std::vector<std::pair<double, double>> rows;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#' || !(std::isdigit(line[0]) || line[0] == '.'))
      continue;
    std::istringstream ss(line);
    double a, b;
    char comma;
    if (ss >> a >> comma >> b)
      rows.push_back({a, b});
  }
  return rows;
}

double interpolate(const std::vector<std::pair<double, double>>& t, double x) {
  for (std::size_t i = 1; i < t.size(); ++i)
    if (x <= t[i].first) {
      const double w = (x - t[i - 1].first) / (t[i].first - t[i - 1].first);
      return t[i - 1].second + w * (t[i].second - t[i - 1].second);
    }
  return t.back().second;
}

} // namespace

class DamBreak : public ::testing::TestWithParam<DensityModel> {};

// Summation density (the paper's Eq. 2) and the continuity equation with delta-SPH diffusion
// (solver.density = "continuity") must both follow the experiment.
INSTANTIATE_TEST_SUITE_P(Density, DamBreak,
                         ::testing::Values(DensityModel::Summation, DensityModel::Continuity),
                         [](const auto& info) {
                           return info.param == DensityModel::Summation ? "Summation"
                                                                        : "Continuity";
                         });

TEST_P(DamBreak, SurgeFrontAndResidualHeightFollowMartinMoyce) {
  const auto front_data = read_csv((test::data_dir() / "martin_moyce_1952.csv").string());
  const auto height_data = read_csv((test::data_dir() / "martin_moyce_1952_height.csv").string());
  ASSERT_GE(front_data.size(), 10u);
  ASSERT_GE(height_data.size(), 10u);
  const double a = 0.1, dp = a / 20, g = 9.81;
  // Quasi-2D: a slab 10 particles thick between walls (no-slip, the default).
  Scene s = test::tank_scene({5 * a, 10 * dp, 3 * a}, {a, 10 * dp, 2 * a}, dp);
  s.solver.kernel = KernelType::CubicSpline;
  s.fluid.eos = EosType::Tait;
  s.fluid.speed_of_sound = 10 * std::sqrt(2 * g * 2 * a); // Mach 0.1 at the largest speed
  s.fluid.viscosity = 0.005;
  s.solver.density = GetParam();
  ASSERT_TRUE(s.fluid.no_slip);
  auto sim = Simulation::create(s, exec::Backend::Cpu);

  const double tscale = std::sqrt(a / (2 * g)); // t = T tscale
  std::vector<double> Ts, Zs, Hs;
  for (double T = 0.5; T <= 2.5 + 1e-9; T += 0.125) {
    const double t = T * tscale;
    while (sim->time() < t - 1e-12)
      sim->step(t);
    const io::Frame fr = sim->frame();
    const auto x = fr.find("fluid")->find("position")->as<float>();
    // The front: the third-largest x of particles near the floor (a lone droplet is not a front),
    // plus half a spacing to reach the fluid's edge. The residual height: the third-highest
    // particle within 2 dp of the back wall, plus half a spacing.
    std::vector<double> xs, zs;
    for (std::size_t i = 0; i < x.size() / 3; ++i) {
      if (x[3 * i + 2] < 0.5 * a)
        xs.push_back(x[3 * i]);
      if (x[3 * i] < 2 * dp)
        zs.push_back(x[3 * i + 2]);
    }
    std::sort(xs.rbegin(), xs.rend());
    std::sort(zs.rbegin(), zs.rend());
    Ts.push_back(T);
    Zs.push_back((xs.at(2) + 0.5 * dp) / a);
    Hs.push_back((zs.at(2) + 0.5 * dp) / (2 * a));
  }

  // Worst relative deviation of the front from the experiment at T + shift.
  auto front_error = [&](double shift) {
    double worst = 0;
    for (std::size_t k = 0; k < Ts.size(); ++k) {
      const double ref = interpolate(front_data, Ts[k] + shift);
      worst = std::max(worst, std::fabs(Zs[k] - ref) / ref);
    }
    return worst;
  };
  auto front_sq = [&](double shift) {
    double sum = 0;
    for (std::size_t k = 0; k < Ts.size(); ++k) {
      const double d = Zs[k] - interpolate(front_data, Ts[k] + shift);
      sum += d * d;
    }
    return sum;
  };
  double best = 0;
  for (double shift = -0.5; shift <= 0.5 + 1e-9; shift += 0.005)
    if (front_sq(shift) < front_sq(best))
      best = shift;

  std::printf("   T      Z   M&M(T)  dev   M&M(T+dT)  dev  |  tau     H   M&M(tau)  dev\n");
  double worst_h = 0;
  for (std::size_t k = 0; k < Ts.size(); ++k) {
    const double z0 = interpolate(front_data, Ts[k]), z1 = interpolate(front_data, Ts[k] + best);
    // tau = t sqrt(g/a) = T / sqrt(2); the height is compared without an offset.
    const double tau = Ts[k] / std::sqrt(2.0), h1 = interpolate(height_data, tau);
    const double dev_h = (Hs[k] - h1) / h1;
    if (tau >= height_data.front().first)
      worst_h = std::max(worst_h, std::fabs(dev_h));
    std::printf("%5.3f %6.3f %6.3f %+6.1f%% %6.3f %+6.1f%%  | %5.3f %6.3f %6.3f %+6.1f%%\n", Ts[k],
                Zs[k], z0, 100 * (Zs[k] - z0) / z0, z1, 100 * (Zs[k] - z1) / z1, tau, Hs[k], h1,
                100 * dev_h);
  }
  const Diagnostics d = sim->diagnostics();
  std::printf("release delay dT = %.3f (%.1f ms in the 57 mm experiment); front: worst %.1f%% "
              "unshifted, %.1f%% at T + dT; residual height worst %.1f%%\n",
              best, 1e3 * best * std::sqrt(0.05715 / (2 * g)), 100 * front_error(0),
              100 * front_error(best), 100 * worst_h);
  std::printf("guard corrections %llu, closest approach to a wall %.2e m\n",
              static_cast<unsigned long long>(d.guard_corrections), d.min_rigid_distance);

  EXPECT_GE(best, 0.0) << "the simulation lags the experiment: that is not a release delay";
  EXPECT_LE(best, 0.3) << "a release delay this long is not plausible (measured 0.245-0.265)";
  EXPECT_LT(front_error(best), 0.065);
  EXPECT_LT(worst_h, 0.04);
  EXPECT_LT(front_error(0), 0.21) << "the unshifted front, measured 19.0-19.4%";
  EXPECT_GT(d.min_rigid_distance, 0.0) << "a particle is inside a wall";
}
