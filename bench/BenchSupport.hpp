#pragma once
// Helpers the bench programs share: the command line, neighbour counts measured on a snapshot
// frame, and the DRAM traffic model of a dam-break step. Host code only; nothing here launches
// kernels.
#include "domain/Scene.hpp"
#include "io/Frame.hpp"

#include <CLI/CLI.hpp>
#include <mpi.h>
#include <optional>
#include <sstream>
#include <string>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <map>
#include <tuple>
#include <vector>

namespace kf::bench {

/// fluid.spacing that gives the scene's fluid blocks about n particles.
inline double spacing_for(const std::string& path, double n) {
  const Scene probe = load_scene(path);
  double volume = 0;
  for (const auto& b : probe.fluid.blocks) {
    const Vec3d e = b.max - b.min;
    volume += e.x * e.y * e.z;
  }
  return std::cbrt(volume / n);
}

/// The --set override for that spacing, with enough digits to reproduce it.
inline std::string spacing_override(double dp) {
  std::ostringstream o;
  o.precision(10);
  o << "fluid.spacing=" << dp;
  return o.str();
}

/// Parses the command line. On --help or a bad option: prints CLI11's text, finalises MPI and
/// returns the exit code to leave main with; otherwise nothing.
inline std::optional<int> parse_or_exit(CLI::App& app, int argc, char** argv) {
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int rc = app.exit(e);
    MPI_Finalize();
    return rc;
  }
  return std::nullopt;
}

/// Mean number of fluid + boundary neighbours within h (pairs the density and force loops
/// evaluate), from a sample of fluid particles, by brute force over a hashed grid on the host.
struct PairCounts {
  double fluid = 0, boundary = 0;
};

inline std::vector<double> positions(const io::Phase& p, bool dbl) {
  if (dbl)
    return p.find("position")->as<double>();
  const auto f = p.find("position")->as<float>();
  return {f.begin(), f.end()};
}

inline PairCounts count_pairs(const io::Frame& fr, double h, bool dbl) {
  const auto x = positions(*fr.find("fluid"), dbl);
  std::vector<double> b;
  if (const io::Phase* p = fr.find("boundary"))
    b = positions(*p, dbl);
  auto key = [h](double px, double py, double pz) {
    return std::make_tuple(long(std::floor(px / h)), long(std::floor(py / h)),
                           long(std::floor(pz / h)));
  };
  std::map<std::tuple<long, long, long>, std::vector<std::size_t>> fc, bc;
  for (std::size_t i = 0; i < x.size() / 3; ++i)
    fc[key(x[3 * i], x[3 * i + 1], x[3 * i + 2])].push_back(i);
  for (std::size_t i = 0; i < b.size() / 3; ++i)
    bc[key(b[3 * i], b[3 * i + 1], b[3 * i + 2])].push_back(i);
  const std::size_t n = x.size() / 3, stride = std::max<std::size_t>(1, n / 2000);
  PairCounts pc;
  std::size_t samples = 0;
  for (std::size_t i = 0; i < n; i += stride, ++samples) {
    const auto [cx, cy, cz] = key(x[3 * i], x[3 * i + 1], x[3 * i + 2]);
    for (long dz = -1; dz <= 1; ++dz)
      for (long dy = -1; dy <= 1; ++dy)
        for (long dx = -1; dx <= 1; ++dx) {
          const auto k = std::make_tuple(cx + dx, cy + dy, cz + dz);
          auto count = [&](const auto& cells, const std::vector<double>& y, double& acc) {
            auto it = cells.find(k);
            if (it == cells.end())
              return;
            for (std::size_t j : it->second) {
              const double ex = y[3 * j] - x[3 * i], ey = y[3 * j + 1] - x[3 * i + 1],
                           ez = y[3 * j + 2] - x[3 * i + 2];
              if (ex * ex + ey * ey + ez * ez < h * h)
                acc += 1;
            }
          };
          count(fc, x, pc.fluid);
          count(bc, b, pc.boundary);
        }
  }
  pc.fluid /= double(samples);
  pc.boundary /= double(samples);
  return pc;
}

/// DRAM traffic one step must make at the least, from the arrays each stage streams (each read
/// or written once; neighbour gathers are assumed to hit in cache, which Morton order makes
/// nearly true). Fluid, per particle, float: kick_drift x v a r/w 60 B; sort keys + permutation
/// 16 B, reorder x v a m id read + write 88 B; density x m read, rho p write 24 B; forces x v rho
/// p m read, a write 40 B; kick v a read, v write 36 B; dt reduction v a 24 B: 288 B.
/// Boundary, per particle: pressure x read, p rho v write 32 B, and read by density and forces
/// x volume p rho (v) 2 x 32 B: 96 B. Doubled in double precision.
inline double bytes_per_step(std::size_t fluid, std::size_t boundary, bool dbl) {
  return (288.0 * double(fluid) + 96.0 * double(boundary)) * (dbl ? 2.0 : 1.0);
}

/// The density and force stages' own share of that model, per fluid particle in float (the
/// itemised 24 B and 40 B above), for per-stage floors.
constexpr double kDensityBytesPerFluid = 24.0;
constexpr double kForcesBytesPerFluid = 40.0;
/// Under solver.density = "continuity": the predictor streams x m v rho drho drho_prev in and p
/// xm vp vol out (80 B, no neighbours); the forces pass also reads rho drho drho_prev and writes
/// them (24 B more).
constexpr double kPredictBytesPerFluid = 80.0;
constexpr double kContinuityForcesBytesPerFluid = kForcesBytesPerFluid + 24.0;

} // namespace kf::bench
