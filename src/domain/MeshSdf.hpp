#pragma once
// The signed distance of a closed mesh (MeshSolid): exact at any point (MeshDistance), and sampled
// on a regular grid (SdfGrid) that RigidShape interpolates during the run. d > 0 outside the solid.
//
// Sign: the angle-weighted pseudonormal of the closest feature (Baerentzen & Aanaes 2005): the
// sign of (p - q) . n, n the normal of the face, the sum of the two face normals of the edge, or
// the angle-weighted sum of the face normals around the vertex on which the closest point q
// lies. It is exact for a closed, consistently oriented mesh (which MeshSolid guarantees), comes
// with the closest-point query at no extra cost, and is local; the generalised winding number
// would tolerate holes, but those are rejected at load anyway, and it costs a sum over every
// triangle per point (or a hierarchy of approximations) instead of one nearest-feature query.
#include "domain/MeshSolid.hpp"
#include "domain/TriangleBvh.hpp"

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace kf {

class MeshDistance {
public:
  /// `mesh` must outlive this object.
  explicit MeshDistance(const MeshSolid& mesh);
  /// Signed distance of p (exact up to rounding). `hint`: a triangle near p (see
  /// TriangleBvh::nearest); it is updated to the triangle found.
  double operator()(const Vec3d& p, std::uint32_t* hint = nullptr) const;

private:
  const MeshSolid& mesh_;
  TriangleBvh bvh_;
  std::vector<Vec3d> face_n_;                // unit normal per triangle (0 when degenerate)
  std::vector<std::array<Vec3d, 3>> edge_n_; // per triangle edge (ab, bc, ca): sum of 2 faces
  std::vector<Vec3d> vertex_n_;              // angle-weighted sum per vertex
};

/// Samples of a signed distance at the nodes origin + (i, j, k) * cell, x fastest.
struct SdfGrid {
  Vec3d origin{};
  double cell = 0;
  std::array<std::uint32_t, 3> dims{};
  std::vector<double> values;

  std::size_t index(std::uint32_t i, std::uint32_t j, std::uint32_t k) const {
    return i + std::size_t(dims[0]) * (j + std::size_t(dims[1]) * k);
  }
  Vec3d node(std::uint32_t i, std::uint32_t j, std::uint32_t k) const {
    return origin + Vec3d{i * cell, j * cell, k * cell};
  }
  Vec3d far_corner() const { return node(dims[0] - 1, dims[1] - 1, dims[2] - 1); }
};

/// Grid resolution: one cell size for all axes, the smallest for which the mesh's bounding box,
/// padded by `margin_cells` on every side, holds at most `max_samples` nodes. 64^3 nodes (2 MiB
/// in double on the host, 1 MiB in float on a device) put ~57 cells along each side of a
/// compact mesh, and more along the long sides of a flat or slender one.
struct SdfResolution {
  std::size_t max_samples = 64 * 64 * 64;
  int margin_cells = 3;
};

/// The grid's geometry alone (no samples), as sample_sdf chooses it.
SdfGrid sdf_grid_geometry(const Vec3d& lo, const Vec3d& hi, const SdfResolution& res = {});

/// Samples the exact signed distance of the mesh at every node (OpenMP over rows of nodes).
SdfGrid sample_sdf(const MeshSolid& mesh, const SdfResolution& res = {});

} // namespace kf
