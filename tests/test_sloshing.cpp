// Sloshing in a closed tank (scenes/studies/sloshing.toml: 0.4 m long, filled 0.2 m deep, the
// water set moving at 0.1 m/s): the first standing wave's period against linear theory,
// omega^2 = g k tanh(k H), k = pi / L (0.7474 s). The water's centre of mass along x is sampled
// every 0.01 s over 2 s and a damped cosine fitted to it (the measure of P7's study,
// jobs/studies/fluid_cases.py), the lists kept over steps ("verlet": 108 s on two threads).
//
// The scene's kernel is Wendland C2 at a support of 3 spacings. At the default 2 the period is
// 5-7% short at every spacing from 0.01 to 0.0025 m (the particle approximation's error falls
// with the neighbours a particle has, not with the spacing); the cubic spline at 3 pairs (9
// particles in 10 within half a spacing of a neighbour by 2 s) and drifts 1.3-1.7% short at
// fine spacings (docs/VALIDATION.md, P7). Measured here at 0.01 m (4,800 particles, the coarsest
// spacing that fills the tank and the fill with whole layers besides 0.02): 0.34% long (lists
// off: 0.42%; the H200's study run 0.23%; 0.45% / 0.38% short at 0.005 / 0.0025 m). The bound,
// 0.6%: the fit's grid (0.02% in omega), the odd modes' bias on a fitted period (at most 0.1%,
// VALIDATION), and the wave's own weakly nonlinear shift (~0.5% at this amplitude, kA ~ 0.1),
// which linear theory leaves out; the same scene at support 2 is 10.5% short ("verlet", 2
// threads; 6.7% at 0.005 m on the H200) and fails it. The particles stay unpaired: 42 of the
// 4,800 (0.9%) within half a spacing of a neighbour at 2 s (lists off 0.85%, the H200's 0.52%).
// The bound, 2%: under the cubic spline's 3% at the onset of its pairing (support 2.25), far
// under its 92% at 3.
#include "domain/Simulation.hpp"
#include "support/TestPaths.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

using namespace kf;

namespace {

struct DampedCosine {
  double omega = 0, gamma = 0, misfit = 0;
};

/// x(t) = c + exp(-gamma t) (a cos(omega t) + b sin(omega t)) by least squares: c, a and b are
/// linear at each (omega, gamma); those two by a grid, coarse (1% in omega, 0.05 /s) and then fine
/// around the coarse best (0.02%, 0.005 /s).
DampedCosine fit_damped_cosine(const std::vector<double>& t, const std::vector<double>& x,
                               double omega_guess) {
  double mean = 0, total = 0;
  for (double v : x)
    mean += v / double(x.size());
  for (double v : x)
    total += (v - mean) * (v - mean);
  auto squares = [&](double w, double g) {
    // Normal equations of the columns 1, e cos, e sin; solved by Cramer's rule (3 x 3).
    double A[3][3] = {}, r[3] = {};
    for (std::size_t i = 0; i < t.size(); ++i) {
      const double e = std::exp(-g * t[i]);
      const double col[3] = {1.0, e * std::cos(w * t[i]), e * std::sin(w * t[i])};
      for (int p = 0; p < 3; ++p) {
        r[p] += col[p] * x[i];
        for (int q = 0; q < 3; ++q)
          A[p][q] += col[p] * col[q];
      }
    }
    auto det = [](const double m[3][3]) {
      return m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) -
             m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
             m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    };
    const double d = det(A);
    double c[3];
    for (int k = 0; k < 3; ++k) {
      double m[3][3];
      for (int p = 0; p < 3; ++p)
        for (int q = 0; q < 3; ++q)
          m[p][q] = q == k ? r[p] : A[p][q];
      c[k] = det(m) / d;
    }
    double sq = 0;
    for (std::size_t i = 0; i < t.size(); ++i) {
      const double e = std::exp(-g * t[i]);
      const double f = c[0] + e * (c[1] * std::cos(w * t[i]) + c[2] * std::sin(w * t[i]));
      sq += (x[i] - f) * (x[i] - f);
    }
    return sq;
  };
  DampedCosine best;
  double best_sq = INFINITY;
  auto search = [&](double w0, double w1, double dw, double g0, double g1, double dg) {
    for (double w = w0; w <= w1; w *= 1 + dw)
      for (double g = std::max(0.0, g0); g <= g1 + 1e-12; g += dg)
        if (const double sq = squares(w, g); sq < best_sq) {
          best_sq = sq;
          best = {w, g, std::sqrt(sq / total)};
        }
  };
  search(0.8 * omega_guess, 1.2 * omega_guess, 0.01, 0.0, 2.0, 0.05);
  const DampedCosine coarse = best;
  search(coarse.omega * 0.98, coarse.omega * 1.02, 0.0002, coarse.gamma - 0.1, coarse.gamma + 0.1,
         0.005);
  return best;
}

} // namespace

TEST(Sloshing, ThePeriodIsLinearTheorysAndTheParticlesDoNotPair) {
  const Scene s = load_scene((test::source_dir() / "scenes" / "studies" / "sloshing.toml").string(),
                             {"output.enabled=false", "fluid.spacing=0.01",
                              "simulation.end_time=2.0", "solver.neighbour_list=\"verlet\""});
  ASSERT_EQ(s.fluid.support, 3.0) << "the scene's support: the bound below is its";
  ASSERT_EQ(s.solver.kernel, KernelType::WendlandC2) << "the scene's kernel: the bounds are its";
  const double L = 0.4, H = 0.2, g = 9.81, k = M_PI / L;
  const double omega0 = std::sqrt(g * k * std::tanh(k * H));
  auto sim = Simulation::create(s, exec::Backend::Cpu);
  std::vector<double> ts, xs;
  for (int n = 0; n <= 200; ++n) {
    const double t = 0.01 * n;
    while (sim->time() < t - 1e-12)
      sim->step(t);
    const io::Frame fr = sim->frame();
    const auto x = fr.find("fluid")->find("position")->as<float>();
    double sum = 0;
    for (std::size_t i = 0; i < x.size() / 3; ++i)
      sum += x[3 * i]; // equal masses: the centre of mass is the mean
    ts.push_back(sim->time());
    xs.push_back(sum / double(x.size() / 3));
  }
  const DampedCosine f = fit_damped_cosine(ts, xs, omega0);
  const double off = omega0 / f.omega - 1; // the period's relative error, + long
  std::printf("period %.4f s against linear theory's %.4f s: %+.2f%%; damping %.3f /s, misfit "
              "%.3f\n",
              2 * M_PI / f.omega, 2 * M_PI / omega0, 100 * off, f.gamma, f.misfit);
  EXPECT_LT(std::fabs(off), 0.006);
  // The fit describes the motion (a misfit of the residual's RMS over the signal's: 0.05 in the
  // study's fit of this run); a fit that missed the wave would not be a period.
  EXPECT_LT(f.misfit, 0.1);
  EXPECT_GT(f.gamma, 0.0) << "the viscosity damps the wave";

  // Pairing, by brute force over every pair: the fraction of particles with a neighbour nearer
  // than half a spacing (none on the starting lattice).
  const auto x = sim->frame().find("fluid")->find("position")->as<float>();
  const std::size_t n = x.size() / 3;
  const double r2 = 0.25 * s.fluid.spacing * s.fluid.spacing;
  std::size_t paired = 0;
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t j = 0; j < n; ++j) {
      const double dx = x[3 * i] - x[3 * j], dy = x[3 * i + 1] - x[3 * j + 1],
                   dz = x[3 * i + 2] - x[3 * j + 2];
      if (j != i && dx * dx + dy * dy + dz * dz < r2) {
        ++paired;
        break;
      }
    }
  std::printf("%zu of %zu particles within half a spacing of a neighbour\n", paired, n);
  EXPECT_LT(double(paired), 0.02 * double(n));
}
