#pragma once
// Nearest triangle of a mesh to a point: a bounding-volume hierarchy (axis-aligned boxes, median
// splits) searched nearest-box-first and pruned by the best distance found so far. Host-only; it
// serves the set-up of mesh obstacles (sampling their signed distance), not the time steps.
#include "core/Vec3.hpp"

#include <array>
#include <cstdint>
#include <vector>

namespace kf {

/// Which part of a triangle (a, b, c) holds the closest point: its interior, an edge (ab, bc,
/// ca) or a vertex. The sign of a distance is read from the pseudonormal of that feature.
enum class TriFeature : std::uint8_t { Face, EdgeAB, EdgeBC, EdgeCA, VertexA, VertexB, VertexC };

struct TriPoint {
  Vec3d q;            // closest point
  TriFeature feature; // where it lies
};

/// The point of triangle (a, b, c) closest to p, by the triangle's Voronoi regions (vertices,
/// then edges, then the interior). Zero-area triangles fall back to their edges.
TriPoint closest_point_on_triangle(const Vec3d& p, const Vec3d& a, const Vec3d& b, const Vec3d& c);

class TriangleBvh {
public:
  using Triangle = std::array<std::uint32_t, 3>;
  TriangleBvh(const std::vector<Vec3d>& vertices, const std::vector<Triangle>& triangles);

  struct Hit {
    std::uint32_t triangle = 0;
    TriPoint point{};
    double d2 = 0; // squared distance
  };
  /// The triangle nearest to p. `hint` (a triangle likely near p, such as the answer for a
  /// neighbouring point) only sets the first bound, so it changes the speed, not the answer.
  Hit nearest(const Vec3d& p, std::uint32_t hint = 0) const;

private:
  struct Node {
    Vec3d lo, hi;
    std::uint32_t first; // leaf: first slot in order_; inner: index of the right child
    std::uint32_t count; // leaf: number of triangles; inner: 0 (the left child is the next node)
  };
  std::uint32_t build(std::uint32_t begin, std::uint32_t end, std::vector<Vec3d>& centroids);
  void test(const Vec3d& p, std::uint32_t t, Hit& best) const;

  const std::vector<Vec3d>& x_;
  const std::vector<Triangle>& tri_;
  std::vector<Node> nodes_;
  std::vector<std::uint32_t> order_; // triangle indices, grouped by leaf
};

} // namespace kf
