#include "domain/SceneSize.hpp"

#include "core/Error.hpp"
#include "domain/MeshObstacle.hpp"
#include "kernels/particles/FluidSet.hpp"
#include "kernels/particles/KnitSet.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <sstream>

namespace kf {

namespace {

/// Points of a lattice of spacing dp over [lo, hi] along one axis (the samplers' rule: cells'
/// centres, at least none).
double lattice_points(double lo, double hi, double dp) {
  return std::max(0.0, std::floor((hi - lo) / dp + 1e-9));
}

/// Particles in a shell `layers` spacings deep behind a surface of this area, at most those of
/// the solid's `volume`.
double shell(double area, double volume, double layers, double dp) {
  return std::min(area * layers / (dp * dp), volume / (dp * dp * dp));
}

/// A box's shell, clipped to the region the boundary lattice covers (the domain and `depth`
/// beyond it: the samplers' lattice; a wall box outside the domain keeps only that slice).
double box_shell(Vec3d lo, Vec3d hi, const Scene& s, double depth, double layers, double dp) {
  const Vec3d reach{depth, depth, depth};
  const Vec3d a = s.domain.min - reach, z = s.domain.max + reach;
  lo = {std::max(lo.x, a.x), std::max(lo.y, a.y), std::max(lo.z, a.z)};
  hi = {std::min(hi.x, z.x), std::min(hi.y, z.y), std::min(hi.z, z.z)};
  const Vec3d b = hi - lo;
  if (!(b.x > 0 && b.y > 0 && b.z > 0))
    return 0;
  return shell(2 * (b.x * b.y + b.y * b.z + b.z * b.x), b.x * b.y * b.z, layers, dp);
}

double obstacle_shell(const Obstacle& o, const Scene& s, double depth, double layers, double dp) {
  const Vec3d e = s.domain.max - s.domain.min;
  switch (o.shape) {
  case ObstacleShape::Box:
    return box_shell(o.min, o.max, s, depth, layers, dp);
  case ObstacleShape::Sphere:
    return shell(4 * M_PI * o.radius * o.radius, 4 / 3.0 * M_PI * std::pow(o.radius, 3), layers,
                 dp);
  case ObstacleShape::Plane: // at most the domain's largest cross-section, times its slant
    return shell(std::sqrt(3.0) * std::max({e.x * e.y, e.y * e.z, e.z * e.x}), e.x * e.y * e.z,
                 layers, dp);
  case ObstacleShape::Mesh: // its box's: the samples lie inside it, near its surface
    return o.mesh ? box_shell(o.mesh->solid.lo, o.mesh->solid.hi, s, depth, layers, dp) : 0;
  }
  return 0;
}

} // namespace

double SceneSize::largest() const {
  return std::max({fluid, boundary, knit});
}

SceneSize estimate_size(const Scene& scene) {
  SceneSize z;
  const bool dbl = scene.precision == Precision::Double;
  const double dp = scene.fluid.spacing, h = scene.support_radius();
  const Vec3d lo = scene.domain.min, hi = scene.domain.max, e = hi - lo;
  if (scene.has(Module::Fluid) && dp > 0) {
    for (const FluidBlock& b : scene.fluid.blocks)
      z.fluid += lattice_points(b.min.x, b.max.x, dp) * lattice_points(b.min.y, b.max.y, dp) *
                 lattice_points(b.min.z, b.max.z, dp);
    const int span = static_cast<int>(scene.solver.cell_span);
    const double cell = h / span;
    z.cells = (std::ceil(e.x / cell) + 2 * span) * (std::ceil(e.y / cell) + 2 * span) *
              (std::ceil(e.z / cell) + 2 * span);
  }
  if (scene.has(Module::Boundary) && dp > 0) {
    const double layers = std::ceil(h / dp - 1e-9);
    const double faces[3] = {e.y * e.z, e.z * e.x, e.x * e.y}; // the walls across x, y, z
    for (int w = 0; w < 6; ++w)
      if (scene.domain.walls[std::size_t(w)])
        z.boundary += faces[w / 2] * layers / (dp * dp);
    for (const Obstacle& o : scene.obstacles)
      z.boundary += obstacle_shell(o, scene, h, layers, dp);
  }
  if (scene.has(Module::Knit))
    for (const KnitPiece& p : scene.knit.pieces)
      if (p.shape != KnitShape::Mesh)
        z.knit += 3.0 * (double(p.wales) + 1) * (double(p.courses) + 1);
  const double fluid_b =
      double(dbl ? FluidSet<double>::bytes_per_particle() : FluidSet<float>::bytes_per_particle());
  const double boundary_b = double(dbl ? BoundarySet<double>::bytes_per_particle()
                                       : BoundarySet<float>::bytes_per_particle());
  // A knit point's set and its share of the springs (~12 a point, two indices and two numbers).
  const double knit_b =
      double(dbl ? KnitSet<double>::bytes_per_particle() : KnitSet<float>::bytes_per_particle()) +
      12.0 * (8 + 2 * (dbl ? 8 : 4));
  z.bytes = z.fluid * fluid_b + z.boundary * boundary_b + z.knit * knit_b +
            z.cells * 3 * sizeof(std::uint32_t) * 2; // the fluid's and the boundary's grids
  return z;
}

std::string format_bytes(double b) {
  const char* unit[] = {"B", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"};
  int k = 0;
  while (b >= 1024 && k < 6) {
    b /= 1024;
    ++k;
  }
  char buf[48];
  std::snprintf(buf, sizeof buf, "%.1f %s", b, unit[k]);
  return buf;
}

void check_size(const Scene& scene, const SceneSize& z, double available, int ranks, int sharing,
                const std::string& where) {
  auto count = [](double n) {
    char buf[32];
    std::snprintf(buf, sizeof buf, n < 1e6 ? "%.0f" : "%.3g", n);
    return std::string(buf);
  };
  std::ostringstream asks;
  asks << "the scene asks for ~" << count(z.fluid) << " fluid, ~" << count(z.boundary)
       << " boundary and ~" << count(z.knit)
       << " knit particles (fluid.spacing = " << scene.fluid.spacing << " m)";
  // Particles and cells are indexed with 32 bits on every backend.
  const double index_limit = double(std::numeric_limits<std::uint32_t>::max());
  if (z.largest() > index_limit || z.cells > index_limit)
    throw InputError(scene.path + ": " + asks.str() + " and a grid of ~" + count(z.cells) +
                     " cells: more than 32-bit indices address (" + count(index_limit) +
                     "); raise fluid.spacing or shrink the domain");
  const double need = z.bytes / std::max(1, ranks) * std::max(1, sharing);
  if (available > 0 && need > available)
    throw InputError(scene.path + ": " + asks.str() + ", ~" + format_bytes(z.bytes) +
                     (ranks > 1 ? " (" + format_bytes(need) + " on this host)" : std::string()) +
                     "; " + where + " has " + format_bytes(available) +
                     ": raise fluid.spacing, shrink the domain or run on more ranks");
}

double available_memory(exec::Backend b) {
  if (b == exec::Backend::Cuda)
    return double(exec::cuda_free_memory_now());
  std::ifstream f("/proc/meminfo");
  std::string key;
  double kib = 0;
  std::string unit;
  while (f >> key >> kib >> unit)
    if (key == "MemAvailable:")
      return kib * 1024;
  return 0;
}

} // namespace kf
