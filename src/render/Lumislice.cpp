#include "render/Lumislice.hpp"

#include "core/Error.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <random>

namespace kf::render {

namespace {

/// A uniform number in [0, 1) from the generator's 32 bits (std's distributions differ between
/// libraries; this does not).
double uniform(std::mt19937& g) {
  return double(g() >> 8) * (1.0 / 16777216.0);
}

} // namespace

float Lumislice::at(const float* field, float x, float y, float outside) const {
  const int n = spec.texels;
  const float h = texel_size(), reach = float(spec.reach());
  const float fx = (x + reach) / h - 0.5f, fy = (y + reach) / h - 0.5f;
  const int i0 = int(std::floor(fx)), j0 = int(std::floor(fy));
  const float ax = fx - float(i0), ay = fy - float(j0);
  auto at = [&](int i, int j) {
    return i < 0 || j < 0 || i >= n || j >= n ? outside : field[std::size_t(j) * n + i];
  };
  return (1 - ay) * ((1 - ax) * at(i0, j0) + ax * at(i0 + 1, j0)) +
         ay * ((1 - ax) * at(i0, j0 + 1) + ax * at(i0 + 1, j0 + 1));
}

Lumislice make_lumislice(const LumisliceSpec& spec) {
  if (spec.plies < 1 || spec.fibres_per_ply < 1 || !(spec.ply_radius > 0) ||
      !(spec.fibre_radius > 0) || spec.texels < 8 || spec.light_directions < 1 || spec.fuzz < 0 ||
      !(spec.fuzz_reach >= 0) || !(spec.extinction >= 0) || !(spec.ply_offset >= 0) ||
      !(spec.twist_pitch > 0) || spec.view_angles < 1)
    throw Error("render: a lumislice needs plies, fibres, radii > 0, a twist pitch > 0, at least "
                "8 texels, 1 light direction and 1 view angle");
  Lumislice s;
  s.spec = spec;
  std::mt19937 g(spec.seed);
  // The plies' fibres: spread over each ply's disc (area-uniform), the ply's centre on a ring.
  for (int p = 0; p < spec.plies; ++p) {
    const double a = 2 * M_PI * p / spec.plies;
    const double cx = spec.ply_offset * std::cos(a), cy = spec.ply_offset * std::sin(a);
    for (int f = 0; f < spec.fibres_per_ply; ++f) {
      const double r = (spec.ply_radius - spec.fibre_radius) * std::sqrt(uniform(g));
      const double b = 2 * M_PI * uniform(g);
      s.fibre_x.push_back(float(cx + r * std::cos(b)));
      s.fibre_y.push_back(float(cy + r * std::sin(b)));
      s.fibre_r.push_back(float(spec.fibre_radius));
    }
  }
  // The fuzz: loose fibres, denser near the plies (the radius 1 + reach u^2).
  for (int f = 0; f < spec.fuzz; ++f) {
    const double u = uniform(g);
    const double r = 1 + (spec.fuzz_reach - spec.fibre_radius) * u * u;
    const double b = 2 * M_PI * uniform(g);
    s.fibre_x.push_back(float(r * std::cos(b)));
    s.fibre_y.push_back(float(r * std::sin(b)));
    s.fibre_r.push_back(float(spec.fibre_radius));
  }
  // Density: 4 x 4 samples a texel, a bit each, set where a fibre covers it (the union).
  const int n = spec.texels;
  const double reach = spec.reach(), h = 2 * reach / n;
  std::vector<std::uint16_t> covered(std::size_t(n) * n, 0);
  for (std::size_t f = 0; f < s.fibre_x.size(); ++f) {
    const double fx = s.fibre_x[f], fy = s.fibre_y[f], fr = s.fibre_r[f];
    const int i0 = std::max(0, int(std::floor((fx - fr + reach) / h)));
    const int i1 = std::min(n - 1, int(std::floor((fx + fr + reach) / h)));
    const int j0 = std::max(0, int(std::floor((fy - fr + reach) / h)));
    const int j1 = std::min(n - 1, int(std::floor((fy + fr + reach) / h)));
    for (int j = j0; j <= j1; ++j)
      for (int i = i0; i <= i1; ++i)
        for (int k = 0; k < 16; ++k) {
          const double x = -reach + (i + ((k & 3) + 0.5) / 4) * h - fx;
          const double y = -reach + (j + ((k >> 2) + 0.5) / 4) * h - fy;
          if (x * x + y * y < fr * fr)
            covered[std::size_t(j) * n + i] |= std::uint16_t(1u << k);
        }
  }
  s.density.resize(covered.size());
  for (std::size_t t = 0; t < covered.size(); ++t)
    s.density[t] = float(std::popcount(covered[t])) / 16.0f;
  // Light: from each texel's centre toward the light, the density integrated to the edge.
  const int dirs = spec.light_directions;
  s.light.resize(std::size_t(dirs) * n * n);
  const float step = float(h / 2);
  const int steps = int(std::ceil(2 * std::sqrt(2.0) * reach / step)) + 1;
#pragma omp parallel for collapse(2) schedule(static)
  for (int d = 0; d < dirs; ++d)
    for (int j = 0; j < n; ++j) {
      const double a = 2 * M_PI * d / dirs;
      const float lx = float(std::cos(a)), ly = float(std::sin(a));
      for (int i = 0; i < n; ++i) {
        const float x = float(-reach + (i + 0.5) * h), y = float(-reach + (j + 0.5) * h);
        // The midpoint rule from the texel's centre outward (its own half step counted).
        double sum = 0;
        for (int k = 0; k < steps; ++k) {
          const float t = (float(k) + 0.5f) * step;
          sum += s.density_at(x + t * lx, y + t * ly);
        }
        s.light[(std::size_t(d) * n + j) * n + i] = float(std::exp(-spec.extinction * sum * step));
      }
    }
  s.ambient.assign(std::size_t(n) * n, 0.0f);
  for (int d = 0; d < dirs; ++d)
    for (std::size_t t = 0; t < s.ambient.size(); ++t)
      s.ambient[t] += s.light[std::size_t(d) * n * n + t] / float(dirs);
  // Seen whole: each line marched front to back across the square's diagonal.
  const int angles = spec.view_angles;
  s.seen_alpha.assign(std::size_t(angles) * n, 0.0f);
  s.seen_ambient.assign(std::size_t(angles) * n, 0.0f);
  s.seen_light.assign(std::size_t(dirs) * angles * n, 0.0f);
  const int across = int(std::ceil(2 * std::sqrt(2.0) * reach / step));
#pragma omp parallel for collapse(2) schedule(static)
  for (int a = 0; a < angles; ++a)
    for (int i = 0; i < n; ++i) {
      const double phi = 2 * M_PI * a / angles;
      const float ux = float(std::cos(phi)), uy = float(std::sin(phi));
      const float x = float(-reach + (i + 0.5) * h);
      double through = 1, ambient = 0;
      std::vector<double> lit(std::size_t(dirs), 0.0);
      for (int k = 0; k < across; ++k) {
        const float t = float(-std::sqrt(2.0) * reach) + (float(k) + 0.5f) * step;
        const float px = -x * uy + t * ux, py = x * ux + t * uy;
        const double d = s.density_at(px, py);
        if (d <= 0)
          continue;
        const double w = through * (1 - std::exp(-spec.extinction * d * step));
        ambient += w * s.at(s.ambient.data(), px, py, 1);
        for (int l = 0; l < dirs; ++l)
          lit[std::size_t(l)] += w * s.at(&s.light[std::size_t(l) * n * n], px, py, 1);
        through -= w;
      }
      const std::size_t at = std::size_t(a) * n + i;
      s.seen_alpha[at] = float(1 - through);
      s.seen_ambient[at] = float(ambient);
      for (int l = 0; l < dirs; ++l)
        s.seen_light[std::size_t(l) * angles * n + at] = float(lit[std::size_t(l)]);
    }
  return s;
}

} // namespace kf::render
