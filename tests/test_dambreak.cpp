// 3D dam break: a water column a wide and 2a high collapses; the surge front x(t) is compared with
// Martin & Moyce (1952) (tests/data/martin_moyce_1952.csv) over T = t sqrt(2g/a) in [0.5, 2.5],
// and no particle may leave the tank or enter a wall.
//
// KNOWN GAP (issue P1, docs/VALIDATION.md): with free-slip walls the front runs ahead of the
// experiment by up to 19% (T = 1.25), 12% at T = 2.5; the goal is 10%. Wall friction
// (no-slip boundary viscosity) is the next step. Until then this guards against regressions at 25%.
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
    if (line.empty() || line[0] == '#' || !(std::isdigit(line[0]) || line[0] == '.')) continue;
    std::istringstream ss(line);
    double a, b;
    char comma;
    if (ss >> a >> comma >> b) rows.push_back({a, b});
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

TEST(DamBreak, SurgeFrontFollowsMartinMoyce) {
  const auto data = read_csv((test::data_dir() / "martin_moyce_1952.csv").string());
  ASSERT_GE(data.size(), 10u);
  const double a = 0.1, dp = a / 20, g = 9.81;
  // Quasi-2D: a slab 10 particles thick between free-slip walls.
  Scene s = test::tank_scene({5 * a, 10 * dp, 3 * a}, {a, 10 * dp, 2 * a}, dp);
  s.solver.kernel = KernelType::CubicSpline;
  s.fluid.eos = EosType::Tait;
  s.fluid.speed_of_sound = 10 * std::sqrt(2 * g * 2 * a); // Mach 0.1 at the largest speed
  s.fluid.viscosity = 0.005;
  auto sim = Simulation::create(s, exec::Backend::Cpu);

  const double tscale = std::sqrt(a / (2 * g)); // t = T tscale
  double worst = 0;
  for (double T = 0.5; T <= 2.5 + 1e-9; T += 0.25) {
    const double t = T * tscale;
    while (sim->time() < t - 1e-12) sim->step(t);
    const io::Frame fr = sim->frame();
    const auto x = fr.find("fluid")->find("position")->as<float>();
    // The front: the third-largest x of particles near the floor (a lone droplet is not a front),
    // plus half a spacing to reach the fluid's edge.
    std::vector<double> xs;
    for (std::size_t i = 0; i < x.size() / 3; ++i)
      if (x[3 * i + 2] < 0.5 * a) xs.push_back(x[3 * i]);
    std::sort(xs.rbegin(), xs.rend());
    const double front = xs.at(2) + 0.5 * dp;
    const double Z = front / a, Zref = interpolate(data, T);
    const double err = (Z - Zref) / Zref;
    worst = std::max(worst, std::fabs(err));
    std::printf("T = %.2f  Z = %.3f  Martin & Moyce %.3f  (%+.1f%%)\n", T, Z, Zref, 100 * err);
    EXPECT_LT(std::fabs(err), 0.25) << "at T = " << T;
  }
  const Diagnostics d = sim->diagnostics();
  std::printf("worst deviation %.1f%%, guard corrections %llu, closest approach to a wall %.2e m\n",
              100 * worst, static_cast<unsigned long long>(d.guard_corrections), d.min_rigid_distance);
  EXPECT_GT(d.min_rigid_distance, 0.0) << "a particle is inside a wall";
}
