#include "domain/Samplers.hpp"

#include "domain/SceneSampler.hpp"

#include "kernels/sph/SmoothingKernels.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <map>
#include <utility>

namespace kf {

namespace {

/// Every sample of the scene's `kind`, in order, and what it took into `work` (its by_points
/// asked for the old rule).
void whole_pass(const Scene& scene, SceneSampler::Kind kind, double dp, double depth,
                const SampleSink& f, SamplerWork* work) {
  const bool by_points = work && work->by_points;
  const SceneSampler s(scene, kind, dp, depth, by_points);
  s.layer_samples(0, s.layers(), 0, f);
  if (work) {
    *work = s.work();
    work->by_points = by_points;
  }
}

} // namespace

std::vector<Vec3d> sample_fluid_block(const FluidBlock& block, double dp) {
  // The block alone, nothing to carve it.
  Scene scene;
  scene.modules = {Module::Fluid};
  scene.fluid.spacing = dp;
  scene.fluid.blocks = {block};
  std::vector<Vec3d> x;
  whole_pass(
      scene, SceneSampler::Kind::Fluid, dp, 0, [&](const Sample& q) { x.push_back(q.x); }, nullptr);
  return x;
}

void for_each_fluid_sample(const Scene& scene, const FluidSampleSink& f, SamplerWork* work) {
  whole_pass(
      scene, SceneSampler::Kind::Fluid, scene.fluid.spacing, 0,
      [&](const Sample& q) { f(q.x, q.v); }, work);
}

FluidSamples sample_fluid(const Scene& scene) {
  FluidSamples out;
  for_each_fluid_sample(scene, [&](const Vec3d& x, const Vec3d& v) {
    out.x.push_back(x);
    out.v.push_back(v);
  });
  return out;
}

namespace {

/// Depth along gravity and the column across it, dp wide (lattice points sit at cell centres, so
/// floor() bins a column without ties).
struct Columns {
  Vec3d down, e1, e2;
  double dp;
  Columns(const Vec3d& gravity, double dp_) : dp(dp_) {
    down = gravity * (1.0 / norm(gravity));
    const Vec3d any = std::abs(down.x) < 0.9 ? Vec3d{1, 0, 0} : Vec3d{0, 1, 0};
    e1 = cross(down, any);
    e1 = e1 * (1.0 / norm(e1));
    e2 = cross(down, e1);
  }
  std::pair<long long, long long> key(const Vec3d& x) const {
    return {static_cast<long long>(std::floor(dot(x, e1) / dp)),
            static_cast<long long>(std::floor(dot(x, e2) / dp))};
  }
  double depth(const Vec3d& x) const { return dot(x, down); }
};

bool at_rest(const Vec3d& v) {
  return v.x == 0 && v.y == 0 && v.z == 0;
}

} // namespace

std::vector<double> hydrostatic_density(const FluidSamples& mine,
                                        const std::function<void(const FluidSampleSink&)>& all,
                                        const Vec3d& gravity, double dp, const Eos<double>& eos) {
  std::vector<double> rho(mine.size(), eos.rho0);
  const double g = norm(gravity);
  if (!(g > 0))
    return rho;
  const Columns c(gravity, dp);
  // The columns of `mine`, each filled with the depths of every sample at rest in it.
  std::map<std::pair<long long, long long>, std::vector<double>> columns;
  for (std::size_t i = 0; i < mine.size(); ++i)
    if (at_rest(mine.v[i]))
      columns.try_emplace(c.key(mine.x[i]));
  all([&](const Vec3d& x, const Vec3d& v) {
    if (!at_rest(v))
      return;
    const auto it = columns.find(c.key(x));
    if (it != columns.end())
      it->second.push_back(c.depth(x));
  });
  // Each column's surfaces, from the top down: each contiguous run (a gap over 1.5 dp starts a
  // new one, a new body of fluid) has its top sample dp / 2 below its surface.
  std::map<std::pair<long long, long long>, std::vector<std::pair<double, double>>> surfaces;
  for (auto& [key, depths] : columns) {
    std::sort(depths.begin(), depths.end());
    auto& s = surfaces[key]; // (depth, the surface above it), by depth
    double surface = depths.front() - 0.5 * dp, previous = depths.front();
    for (const double d : depths) {
      if (d - previous > 1.5 * dp)
        surface = d - 0.5 * dp;
      previous = d;
      s.emplace_back(d, surface);
    }
    depths = {};
  }
  for (std::size_t i = 0; i < mine.size(); ++i) {
    if (!at_rest(mine.v[i]))
      continue;
    const auto& s = surfaces.at(c.key(mine.x[i]));
    const double d = c.depth(mine.x[i]);
    const auto it = std::lower_bound(s.begin(), s.end(), std::make_pair(d, -1e300));
    rho[i] = eos.density(eos.rho0 * g * (d - it->second));
  }
  return rho;
}

std::vector<double> hydrostatic_density(const FluidSamples& fs, const Vec3d& gravity, double dp,
                                        const Eos<double>& eos) {
  return hydrostatic_density(
      fs,
      [&](const FluidSampleSink& f) {
        for (std::size_t i = 0; i < fs.size(); ++i)
          f(fs.x[i], fs.v[i]);
      },
      gravity, dp, eos);
}

double lattice_particle_mass(KernelType kernel, double support, double dp, double rho0) {
  const double h = support * dp;
  const int r = static_cast<int>(std::ceil(support)) + 1;
  double sum = 0;
  with_kernel<double>(kernel, h, [&](auto k) {
    for (int i = -r; i <= r; ++i)
      for (int j = -r; j <= r; ++j)
        for (int l = -r; l <= r; ++l)
          sum += k.W(dp * std::sqrt(double(i * i + j * j + l * l)));
    return 0;
  });
  return rho0 / sum;
}

void for_each_boundary_sample(const Scene& scene, double dp, double depth,
                              const BoundarySampleSink& f, SamplerWork* work) {
  whole_pass(
      scene, SceneSampler::Kind::Boundary, dp, depth,
      [&](const Sample& q) { f(q.x, q.obstacle, q.volume_scale); }, work);
}

BoundarySamples sample_boundaries(const Scene& scene, double dp, double depth) {
  BoundarySamples out;
  for_each_boundary_sample(scene, dp, depth,
                           [&](const Vec3d& x, std::uint32_t obstacle, double volume_scale) {
                             out.x.push_back(x);
                             out.obstacle.push_back(obstacle);
                             out.volume_scale.push_back(volume_scale);
                           });
  return out;
}

} // namespace kf
