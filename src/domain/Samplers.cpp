#include "domain/Samplers.hpp"

#include "domain/RigidShapes.hpp"

#include "kernels/particles/FluidSet.hpp"
#include "kernels/sph/SmoothingKernels.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <utility>

namespace kf {

namespace {

int cells_along(double length, double dp) {
  return std::max(0, static_cast<int>(std::floor(length / dp + 1e-9)));
}

/// A number in [-0.5, 0.5) from a lattice point and an axis (splitmix64's finaliser): the
/// jitter depends on nothing but the point, so every run and rank samples the same start.
double jitter_of(std::uint64_t point, int axis) {
  std::uint64_t z = point * 3 + static_cast<std::uint64_t>(axis) + 0x9E3779B97F4A7C15ull;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  z ^= z >> 31;
  return static_cast<double>(z >> 11) * 0x1.0p-53 - 0.5;
}

} // namespace

std::vector<Vec3d> sample_fluid_block(const FluidBlock& block, double dp) {
  const Vec3d e = block.max - block.min;
  const int nx = cells_along(e.x, dp), ny = cells_along(e.y, dp), nz = cells_along(e.z, dp);
  std::vector<Vec3d> x;
  x.reserve(static_cast<std::size_t>(nx) * ny * nz);
  const double a = block.jitter * dp;
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        Vec3d p = block.min + Vec3d{(i + 0.5) * dp, (j + 0.5) * dp, (k + 0.5) * dp};
        if (a > 0) {
          const std::uint64_t n = (std::uint64_t(k) * ny + j) * nx + i;
          p += Vec3d{a * jitter_of(n, 0), a * jitter_of(n, 1), a * jitter_of(n, 2)};
        }
        x.push_back(p);
      }
  return x;
}

void for_each_fluid_sample(const Scene& scene, const FluidSampleSink& f) {
  // Blocks are carved by the solids at t = 0 (a pool around a submerged sphere is one block):
  // a lattice point closer than dp/4 to a solid or inside it is left out. Walls aligned with the
  // lattice keep their first layer (dp/2 from the wall); the boundary shell starts inside the
  // solid.
  const RigidShapes<double> solids(scene);
  const auto& shapes = solids.table();
  const bool carve = scene.has(Module::Boundary);
  const double keep = 0.25 * scene.fluid.spacing;
  for (const auto& b : scene.fluid.blocks)
    for (const Vec3d& p : sample_fluid_block(b, scene.fluid.spacing)) {
      bool free = true;
      Vec3d n;
      if (carve)
        for (const auto& s : shapes)
          free = free && s.distance(p, n) >= keep;
      if (free)
        f(p, b.velocity);
    }
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

namespace {

/// Boundary lattice coordinates along one axis of the domain [lo, hi], with the spacing each
/// point stands for. Inside, n = round((hi - lo) / dp) points evenly over the domain (spacing
/// (hi - lo) / n, which is dp when the domain is a multiple of dp); outside each face, layers at
/// (k + 1/2) dp from that face. So every wall has its first layer half a spacing behind it and no
/// hole, whatever the domain's size (a gap there lets fluid sink through the floor).
struct AxisLattice {
  std::vector<double> x, spacing;
};

AxisLattice axis_lattice(double lo, double hi, double dp, double depth) {
  AxisLattice a;
  const int layers = static_cast<int>(std::ceil(depth / dp - 1e-9));
  const int n = std::max(1, static_cast<int>(std::lround((hi - lo) / dp)));
  const double s = (hi - lo) / n;
  auto add = [&](double x, double w) {
    a.x.push_back(x);
    a.spacing.push_back(w);
  };
  for (int k = layers - 1; k >= 0; --k)
    add(lo - (k + 0.5) * dp, dp);
  for (int i = 0; i < n; ++i)
    add(lo + (i + 0.5) * s, s);
  for (int k = 0; k < layers; ++k)
    add(hi + (k + 0.5) * dp, dp);
  return a;
}

} // namespace

void for_each_boundary_sample(const Scene& scene, double dp, double depth,
                              const BoundarySampleSink& f) {
  // The lattice of the fluid (aligned with the domain) continued into every solid, one shell of
  // thickness `depth` deep: at rest a flat wall is then an exact mirror of the fluid, and one
  // rule samples walls, boxes, spheres, planes and meshes (their sampled distance) alike. When the
  // domain is not a multiple of dp the lattice is stretched to fit it (axis_lattice) and each
  // particle's volume scales with it.
  const RigidShapes<double> solids(scene);
  const auto& shapes = solids.table();
  const std::size_t container = scene.obstacles.size(); // index of the walls, if any are closed
  const Vec3d& lo = scene.domain.min;
  const Vec3d& hi = scene.domain.max;
  const AxisLattice ax = axis_lattice(lo.x, hi.x, dp, depth);
  const AxisLattice ay = axis_lattice(lo.y, hi.y, dp, depth);
  const AxisLattice az = axis_lattice(lo.z, hi.z, dp, depth);
  for (std::size_t k = 0; k < az.x.size(); ++k)
    for (std::size_t j = 0; j < ay.x.size(); ++j)
      for (std::size_t i = 0; i < ax.x.size(); ++i) {
        const Vec3d p{ax.x[i], ay.x[j], az.x[k]};
        for (std::size_t s = 0; s < shapes.size(); ++s) {
          Vec3d n;
          const double d = shapes[s].distance(p, n);
          if (d < 0 && d >= -depth) {
            f(p, s == container ? kWallObstacle : static_cast<std::uint32_t>(s),
              ax.spacing[i] * ay.spacing[j] * az.spacing[k] / (dp * dp * dp));
            break;
          }
        }
      }
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
