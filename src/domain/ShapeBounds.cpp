#include "domain/ShapeBounds.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace kf {

namespace {

/// The smallest node value on the six faces of a mesh's grid.
double face_floor(const RigidShape<double>& s) {
  const std::uint32_t nx = s.dims[0], ny = s.dims[1], nz = s.dims[2];
  double least = std::numeric_limits<double>::infinity();
  for (std::uint32_t k = 0; k < nz; ++k)
    for (std::uint32_t j = 0; j < ny; ++j) {
      const bool side = k == 0 || k + 1 == nz || j == 0 || j + 1 == ny;
      for (std::uint32_t i = 0; i < nx; i += (side || i + 1 == nx) ? 1 : nx - 1)
        least = std::min(least, s.sdf[i + std::size_t(nx) * (j + std::size_t(ny) * k)]);
    }
  return least;
}

} // namespace

ShapeBounds::ShapeBounds(const std::vector<RigidShape<double>>& table)
    : table_(&table), face_floor_(table.size(), 0.0) {
  for (std::size_t s = 0; s < table.size(); ++s)
    if (table[s].kind == ShapeKind::Mesh)
      face_floor_[s] = face_floor(table[s]);
}

DistanceBounds ShapeBounds::over(std::size_t s, const PointBox& box) const {
  constexpr double inf = std::numeric_limits<double>::infinity();
  const RigidShape<double>& shape = (*table_)[s];
  // In the shape's frame.
  const Vec3d lo = box.lo - shape.offset, hi = box.hi - shape.offset;
  const double l[3] = {lo.x, lo.y, lo.z}, h[3] = {hi.x, hi.y, hi.z}, e = box.spread;
  switch (shape.kind) {
  case ShapeKind::Plane: { // linear: its extremes at the box's corners
    const double n[3] = {shape.b.x, shape.b.y, shape.b.z}, p[3] = {shape.a.x, shape.a.y, shape.a.z};
    double least = 0, most = 0;
    for (int a = 0; a < 3; ++a) {
      least += std::min(n[a] * (l[a] - p[a]), n[a] * (h[a] - p[a]));
      most += std::max(n[a] * (l[a] - p[a]), n[a] * (h[a] - p[a]));
    }
    const double reach = norm(shape.b) * e;
    return {least - reach, most + reach};
  }
  case ShapeKind::Container: { // the least of the closed walls' gaps, each linear along an axis
    const double wlo[3] = {shape.a.x, shape.a.y, shape.a.z},
                 whi[3] = {shape.b.x, shape.b.y, shape.b.z};
    double least = 1e30, most = 1e30; // no closed wall: container_distance's 1e30
    for (int w = 0; w < 6; ++w) {
      if (!(shape.walls >> w & 1u))
        continue;
      const int a = w / 2;
      const double g0 = (w & 1) ? whi[a] - h[a] : l[a] - wlo[a],
                   g1 = (w & 1) ? whi[a] - l[a] : h[a] - wlo[a];
      least = std::min(least, g0 - e);
      most = std::min(most, g1 + e);
    }
    return {least, most};
  }
  case ShapeKind::Mesh: { // the gap from the box to the grid's box
    double gap2 = 0;
    const double ga[3] = {shape.a.x, shape.a.y, shape.a.z},
                 gb[3] = {shape.b.x, shape.b.y, shape.b.z};
    for (int a = 0; a < 3; ++a) {
      const double g = std::max({ga[a] - h[a], l[a] - gb[a], 0.0});
      gap2 += g * g;
    }
    const double gap = std::sqrt(gap2) - e;
    if (gap > 0)
      return {gap + face_floor_[s], inf};
    return {-inf, inf};
  }
  default: { // spheres and boxes: the distance at the centre, the box's radius either side
    const Vec3d centre = (box.lo + box.hi) * 0.5;
    const double radius = 0.5 * norm(box.hi - box.lo) + e;
    Vec3d normal;
    const double d = shape.distance(centre, normal);
    return {d - radius, d + radius};
  }
  }
}

} // namespace kf
