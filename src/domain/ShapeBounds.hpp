#pragma once
// Bounds on a solid's signed distance over a ball, from one evaluation at its centre: what lets
// the samplers pass over the lattice points far from every solid's surface without evaluating
// each (domain/LatticeSieve). Host-only.
#include "core/Vec3.hpp"
#include "kernels/boundary/RigidShape.hpp"

#include <vector>

namespace kf {

/// lower <= distance(x) <= upper for every x of a PointBox (either may be infinite).
struct DistanceBounds {
  double lower, upper;
};

/// The points within `spread` of the box [lo, hi].
struct PointBox {
  Vec3d lo, hi;
  double spread = 0;
};

/// The bounds of each shape of a table (RigidShapes<double>'s on the host, which must outlive
/// this). A plane's distance is linear and a container's the least of its closed walls' (each
/// linear along one axis): their bounds over a box are exact. Spheres and boxes are exact
/// signed distances, |d(x) - d(c)| <= |x - c|: the distance at the box's centre, less and plus
/// its radius. A mesh's sampled distance is trilinear between its grid's nodes, with no such
/// constant inside the grid; beyond the grid's box it is the distance to the box plus the value
/// at the box's nearest point, at least the smallest value on the box's faces: bounded from
/// below there, unbounded inside.
class ShapeBounds {
public:
  explicit ShapeBounds(const std::vector<RigidShape<double>>& table);
  std::size_t size() const { return table_->size(); }
  DistanceBounds over(std::size_t s, const PointBox& box) const;

private:
  const std::vector<RigidShape<double>>* table_;
  std::vector<double> face_floor_; // a mesh's smallest sampled value on its grid's faces
};

} // namespace kf
