// "verlet" neighbour lists (SphLists): lists of the support plus a skin, kept with the fluid's
// order and grid over steps until some particle may have moved half the skin. They must never
// miss a pair: at every checked step each fluid particle's density (Eq. 2 plus the boundary
// term, as the run computed it) is compared with a brute-force sum over all fluid and boundary
// particles at the frame's positions. The lists must also be kept: fewer sorts than steps.
#include "domain/Scene.hpp"
#include "domain/Simulation.hpp"
#include "io/Frame.hpp"
#include "kernels/sph/SmoothingKernels.hpp"
#include "support/TestPaths.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <unordered_map>
#include <vector>

using namespace kf;

namespace {

template <typename T>
std::vector<double> field(const io::Phase& p, const char* name) {
  const io::Field* f = p.find(name);
  EXPECT_NE(f, nullptr) << name;
  const auto v = f->as<T>();
  return std::vector<double>(v.begin(), v.end());
}

/// Largest |rho_run - rho_brute| / rho0 over the fluid of one frame.
template <typename T>
double density_error(const Scene& s, const io::Frame& fr) {
  const io::Phase* fp = fr.find("fluid");
  const io::Phase* bp = fr.find("boundary");
  EXPECT_NE(fp, nullptr);
  const auto x = field<T>(*fp, "position"), m = field<T>(*fp, "mass"),
             rho = field<T>(*fp, "density");
  std::vector<double> xb, vb;
  if (bp) {
    xb = field<T>(*bp, "position");
    vb = field<T>(*bp, "volume");
  }
  const double h = s.support_radius(), rho0 = s.fluid.rest_density;
  return with_kernel<double>(s.solver.kernel, h, [&](auto k) {
    double worst = 0;
    const std::size_t n = m.size();
    for (std::size_t i = 0; i < n; ++i) {
      auto dist2 = [&](const std::vector<double>& y, std::size_t j) {
        const double dx = x[3 * i] - y[3 * j], dy = x[3 * i + 1] - y[3 * j + 1],
                     dz = x[3 * i + 2] - y[3 * j + 2];
        return dx * dx + dy * dy + dz * dz;
      };
      double sum = 0, vol = 0;
      for (std::size_t j = 0; j < n; ++j)
        if (const double r2 = dist2(x, j); r2 < h * h)
          sum += m[j] * k.W(std::sqrt(r2));
      for (std::size_t b = 0; b < vb.size(); ++b)
        if (const double r2 = dist2(xb, b); r2 < h * h)
          vol += vb[b] * k.W(std::sqrt(r2));
      worst = std::max(worst, std::abs(rho[i] - (sum + rho0 * vol)) / rho0);
    }
    return worst;
  });
}

struct Run {
  std::vector<double> worst; // density error at each checked step
  std::uint64_t sorts = 0, steps = 0;
};

template <typename T>
Run run(const std::string& file, std::vector<std::string> overrides, int steps, int every) {
  overrides.push_back("output.enabled=false");
  overrides.push_back("solver.neighbour_list=\"verlet\"");
  overrides.push_back(std::string("simulation.precision=\"") +
                      (sizeof(T) == 4 ? "float" : "double") + "\"");
  const Scene s = load_scene((test::source_dir() / "scenes" / file).string(), overrides);
  auto sim = Simulation::create(s, exec::Backend::Cpu);
  Run r;
  for (int k = 1; k <= steps; ++k) {
    sim->step(1e30);
    if (k % every == 0)
      r.worst.push_back(density_error<T>(s, sim->frame()));
  }
  r.sorts = sim->diagnostics().fluid_sorts;
  r.steps = sim->steps();
  return r;
}

// Rounding: about 30-170 terms of size ~rho0 / 30 summed in another order than the brute force.
template <typename T>
constexpr double kTol = sizeof(T) == 4 ? 2e-5 : 1e-11;

template <typename T>
void check(const Run& r, const char* what) {
  for (std::size_t c = 0; c < r.worst.size(); ++c)
    EXPECT_LT(r.worst[c], kTol<T>) << what << ": check " << c << " of " << r.worst.size();
  // Kept over steps (the lists paid off), and built again as the fluid moved (the rule ran).
  EXPECT_LT(r.sorts * 3, r.steps) << what << ": " << r.sorts << " sorts in " << r.steps;
  EXPECT_GE(r.sorts, 3u) << what << ": the fluid never moved half the skin";
}

} // namespace

// Dam break at dp = 2 cm: the host's bound on the motion decides most steps without a read.
TEST(VerletLists, DamBreakDensityIsTheBruteForceSum) {
  check<float>(run<float>("dambreak.toml", {"fluid.spacing=0.02"}, 300, 20), "float");
  check<double>(run<double>("dambreak.toml", {"fluid.spacing=0.02"}, 300, 20), "double");
}

// The column benchmark's wide support (3.46 dp, ~170 neighbours), coarse, with a small skin so
// that builds are frequent. Summation density (the scene integrates it), which the check sums.
TEST(VerletLists, WideSupportSmallSkin) {
  check<float>(run<float>("bench/dambreak_column.toml",
                          {"fluid.spacing=0.03", "solver.neighbour_skin=0.05",
                           "solver.density=\"summation\""},
                          200, 25),
               "column");
}

// The pour: the knit's coupling changes fluid velocities after the step's bounds were read, so
// every step reads the device's record of the motion instead.
TEST(VerletLists, CoupledPourReadsTheMotion) {
  check<double>(run<double>("pour.toml",
                            {"fluid.spacing=0.01", "knit.piece.0.wales=32",
                             "knit.piece.0.courses=32", "fluid.block.0.min=[-0.04, -0.04, 0.53]",
                             "fluid.block.0.max=[0.04, 0.04, 0.73]"},
                            150, 25),
                "pour");
}

TEST(VerletLists, SkinOutOfRangeIsAnError) {
  try {
    load_scene((test::source_dir() / "scenes" / "dambreak.toml").string(),
               {"solver.neighbour_skin=1.5"});
    FAIL() << "a skin of 1.5 h was accepted";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("solver.neighbour_skin"), std::string::npos) << e.what();
  }
}
