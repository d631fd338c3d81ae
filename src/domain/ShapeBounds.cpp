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

DistanceBounds ShapeBounds::over(std::size_t s, const Vec3d& centre, double radius) const {
  constexpr double inf = std::numeric_limits<double>::infinity();
  const RigidShape<double>& shape = (*table_)[s];
  if (shape.kind == ShapeKind::Mesh) {
    const Vec3d x = centre - shape.offset;
    // The distance from the ball's centre to the grid's box, less the radius: the gap from
    // every point of the ball to the box.
    const double ox = std::max({shape.a.x - x.x, x.x - shape.b.x, 0.0});
    const double oy = std::max({shape.a.y - x.y, x.y - shape.b.y, 0.0});
    const double oz = std::max({shape.a.z - x.z, x.z - shape.b.z, 0.0});
    const double gap = std::sqrt(ox * ox + oy * oy + oz * oz) - radius;
    if (gap > 0)
      return {gap + face_floor_[s], inf};
    return {-inf, inf};
  }
  Vec3d normal;
  const double d = shape.distance(centre, normal);
  const double lipschitz = shape.kind == ShapeKind::Plane ? norm(shape.b) : 1.0;
  return {d - lipschitz * radius, d + lipschitz * radius};
}

} // namespace kf
