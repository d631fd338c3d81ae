#include "domain/Samplers.hpp"

#include "domain/LatticeSieve.hpp"
#include "domain/RigidShapes.hpp"
#include "domain/ShapeBounds.hpp"

#include "kernels/particles/FluidSet.hpp"
#include "kernels/sph/SmoothingKernels.hpp"

#include <algorithm>
#include <array>
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

namespace {

/// A fluid block's lattice: points at cell centres, each moved by its own jitter.
struct BlockLattice {
  Vec3d min;
  double dp, amplitude; // the jitter's: each coordinate moves by less than amplitude / 2
  int nx, ny, nz;
  BlockLattice(const FluidBlock& block, double dp_)
      : min(block.min), dp(dp_), amplitude(block.jitter * dp_) {
    const Vec3d e = block.max - block.min;
    nx = cells_along(e.x, dp), ny = cells_along(e.y, dp), nz = cells_along(e.z, dp);
  }
  Vec3d point(int i, int j, int k) const {
    Vec3d p = min + Vec3d{(i + 0.5) * dp, (j + 0.5) * dp, (k + 0.5) * dp};
    if (amplitude > 0) {
      const std::uint64_t n = (std::uint64_t(k) * ny + j) * nx + i;
      p += Vec3d{amplitude * jitter_of(n, 0), amplitude * jitter_of(n, 1),
                 amplitude * jitter_of(n, 2)};
    }
    return p;
  }
  std::array<std::vector<double>, 3> axes() const {
    std::array<std::vector<double>, 3> at;
    const int n[3] = {nx, ny, nz};
    const double lo[3] = {min.x, min.y, min.z};
    for (int a = 0; a < 3; ++a)
      for (int i = 0; i < n[a]; ++i)
        at[a].push_back(lo[a] + (i + 0.5) * dp);
    return at;
  }
};

// A box's class for the fluid's carving (a point is kept where every solid lies at least keep
// away); and the boundary's, where shape s's shell holds every point: kAllOf + s.
constexpr std::uint8_t kFree = 0, kCarved = 1, kNone = 254, kAllOf = 0;

/// The bounds decide a point only this far inside an outcome: the distances at the points, each
/// rounded, cannot then cross an edge the bound put them beyond (rounding is ~1e-16 of a
/// coordinate).
double decided_by(double dp) {
  return 1e-6 * dp;
}

} // namespace

std::vector<Vec3d> sample_fluid_block(const FluidBlock& block, double dp) {
  const BlockLattice l(block, dp);
  std::vector<Vec3d> x;
  x.reserve(static_cast<std::size_t>(l.nx) * l.ny * l.nz);
  for (int k = 0; k < l.nz; ++k)
    for (int j = 0; j < l.ny; ++j)
      for (int i = 0; i < l.nx; ++i)
        x.push_back(l.point(i, j, k));
  return x;
}

void for_each_fluid_sample(const Scene& scene, const FluidSampleSink& f, SamplerWork* work) {
  // Blocks are carved by the solids at t = 0 (a pool around a submerged sphere is one block):
  // a lattice point closer than dp/4 to a solid or inside it is left out. Walls aligned with the
  // lattice keep their first layer (dp/2 from the wall); the boundary shell starts inside the
  // solid.
  const RigidShapes<double> solids(scene);
  const auto& shapes = solids.table();
  const ShapeBounds bounds(shapes);
  const bool carve = scene.has(Module::Boundary) && !shapes.empty();
  const double dp = scene.fluid.spacing, keep = 0.25 * dp, tol = decided_by(dp);
  SamplerWork done;
  done.by_points = work && work->by_points;
  const auto kept = [&](const Vec3d& p) {
    ++done.tested;
    for (const auto& s : shapes) {
      Vec3d n;
      if (!(s.distance(p, n) >= keep))
        return false;
    }
    return true;
  };
  BallClassifier classify = [&](const Vec3d& c, double r) {
    bool free = true;
    for (std::size_t s = 0; s < shapes.size(); ++s) {
      const DistanceBounds d = bounds.over(s, c, r);
      if (d.upper < keep - tol)
        return kCarved;
      free = free && d.lower >= keep + tol;
    }
    return free ? kFree : kSieveMaybe;
  };
  if (done.by_points)
    classify = nullptr;
  for (const auto& b : scene.fluid.blocks) {
    const BlockLattice l(b, dp);
    done.points += std::uint64_t(l.nx) * l.ny * l.nz;
    if (!carve) {
      for (int k = 0; k < l.nz; ++k)
        for (int j = 0; j < l.ny; ++j)
          for (int i = 0; i < l.nx; ++i)
            f(l.point(i, j, k), b.velocity);
      continue;
    }
    // A jittered point lies within sqrt(3) amplitude / 2 of its lattice position.
    const LatticeSieve sieve(l.axes(), std::max(0.0, 0.5 * std::sqrt(3.0) * l.amplitude), classify);
    sieve.for_each([&](int i, int j, int k, std::uint8_t c) {
      if (c == kCarved)
        return;
      const Vec3d p = l.point(i, j, k);
      if (c == kFree || kept(p))
        f(p, b.velocity);
    });
    done.boxes += sieve.classifications();
  }
  if (work)
    *work = done;
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
                              const BoundarySampleSink& f, SamplerWork* work) {
  // The lattice of the fluid (aligned with the domain) continued into every solid, one shell of
  // thickness `depth` deep: at rest a flat wall is then an exact mirror of the fluid, and one
  // rule samples walls, boxes, spheres, planes and meshes (their sampled distance) alike. When the
  // domain is not a multiple of dp the lattice is stretched to fit it (axis_lattice) and each
  // particle's volume scales with it.
  const RigidShapes<double> solids(scene);
  const auto& shapes = solids.table();
  const ShapeBounds bounds(shapes);
  const std::size_t container = scene.obstacles.size(); // index of the walls, if any are closed
  const Vec3d& lo = scene.domain.min;
  const Vec3d& hi = scene.domain.max;
  const AxisLattice ax = axis_lattice(lo.x, hi.x, dp, depth);
  const AxisLattice ay = axis_lattice(lo.y, hi.y, dp, depth);
  const AxisLattice az = axis_lattice(lo.z, hi.z, dp, depth);
  const double tol = decided_by(dp);
  // A point is shape s's where s is the first whose shell (-depth <= d < 0) holds it.
  const auto emit = [&](std::size_t i, std::size_t j, std::size_t k, std::size_t s) {
    f(Vec3d{ax.x[i], ay.x[j], az.x[k]},
      s == container ? kWallObstacle : static_cast<std::uint32_t>(s),
      ax.spacing[i] * ay.spacing[j] * az.spacing[k] / (dp * dp * dp));
  };
  BallClassifier classify = [&](const Vec3d& c, double r) {
    for (std::size_t s = 0; s < shapes.size(); ++s) {
      const DistanceBounds d = bounds.over(s, c, r);
      const bool out = d.lower >= tol || d.upper < -depth - tol;
      if (out)
        continue;
      const bool in = d.lower >= -depth + tol && d.upper < -tol;
      return in && kAllOf + s < kNone ? static_cast<std::uint8_t>(kAllOf + s) : kSieveMaybe;
    }
    return kNone;
  };
  const bool by_points = work && work->by_points;
  if (by_points)
    classify = nullptr;
  const LatticeSieve sieve({ax.x, ay.x, az.x}, 0.0, classify);
  std::uint64_t tested = 0;
  sieve.for_each([&](int i, int j, int k, std::uint8_t c) {
    if (c == kNone)
      return;
    if (c != kSieveMaybe) {
      emit(i, j, k, c - kAllOf);
      return;
    }
    const Vec3d p{ax.x[i], ay.x[j], az.x[k]};
    ++tested;
    for (std::size_t s = 0; s < shapes.size(); ++s) {
      Vec3d n;
      const double d = shapes[s].distance(p, n);
      if (d < 0 && d >= -depth) {
        emit(i, j, k, s);
        break;
      }
    }
  });
  if (work)
    *work = {by_points, std::uint64_t(ax.x.size()) * ay.x.size() * az.x.size(),
             sieve.classifications(), tested};
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
