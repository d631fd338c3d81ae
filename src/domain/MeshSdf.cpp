#include "domain/MeshSdf.hpp"

#include <algorithm>
#include <cmath>

namespace kf {

namespace {

Vec3d unit_or_zero(const Vec3d& v) {
  const double n = norm(v);
  return n > 0 ? v * (1.0 / n) : Vec3d{0, 0, 0};
}

double angle_between(const Vec3d& u, const Vec3d& v) {
  const double c = dot(unit_or_zero(u), unit_or_zero(v));
  return std::acos(std::clamp(c, -1.0, 1.0));
}

} // namespace

MeshDistance::MeshDistance(const MeshSolid& mesh)
    : mesh_(mesh), bvh_(mesh.vertices, mesh.triangles) {
  const auto& x = mesh.vertices;
  const auto& tri = mesh.triangles;
  face_n_.resize(tri.size());
  vertex_n_.assign(x.size(), Vec3d{0, 0, 0});
  std::vector<std::pair<std::uint64_t, std::uint32_t>> directed; // (from << 32 | to, triangle)
  directed.reserve(3 * tri.size());
  for (std::uint32_t t = 0; t < tri.size(); ++t) {
    const auto& v = tri[t];
    // A zero-area triangle has no direction; it adds nothing to its edges and vertices.
    face_n_[t] = unit_or_zero(cross(x[v[1]] - x[v[0]], x[v[2]] - x[v[0]]));
    for (int k = 0; k < 3; ++k) {
      const Vec3d& here = x[v[k]];
      const double alpha = angle_between(x[v[(k + 1) % 3]] - here, x[v[(k + 2) % 3]] - here);
      vertex_n_[v[k]] += face_n_[t] * alpha;
      directed.push_back({std::uint64_t(v[k]) << 32 | v[(k + 1) % 3], t});
    }
  }
  std::sort(directed.begin(), directed.end());
  edge_n_.resize(tri.size());
  for (std::uint32_t t = 0; t < tri.size(); ++t)
    for (int k = 0; k < 3; ++k) {
      // The neighbour runs the edge the other way (the mesh is closed and oriented).
      const std::uint64_t back = std::uint64_t(tri[t][(k + 1) % 3]) << 32 | tri[t][k];
      const auto it = std::lower_bound(directed.begin(), directed.end(),
                                       std::pair<std::uint64_t, std::uint32_t>{back, 0});
      const Vec3d other =
          it != directed.end() && it->first == back ? face_n_[it->second] : Vec3d{0, 0, 0};
      edge_n_[t][k] = face_n_[t] + other;
    }
}

double MeshDistance::operator()(const Vec3d& p, std::uint32_t* hint) const {
  const TriangleBvh::Hit h = bvh_.nearest(p, hint ? *hint : 0);
  if (hint)
    *hint = h.triangle;
  const auto& v = mesh_.triangles[h.triangle];
  Vec3d n{0, 0, 0};
  switch (h.point.feature) {
  case TriFeature::Face:
    n = face_n_[h.triangle];
    break;
  case TriFeature::EdgeAB:
    n = edge_n_[h.triangle][0];
    break;
  case TriFeature::EdgeBC:
    n = edge_n_[h.triangle][1];
    break;
  case TriFeature::EdgeCA:
    n = edge_n_[h.triangle][2];
    break;
  case TriFeature::VertexA:
    n = vertex_n_[v[0]];
    break;
  case TriFeature::VertexB:
    n = vertex_n_[v[1]];
    break;
  case TriFeature::VertexC:
    n = vertex_n_[v[2]];
    break;
  }
  const double d = std::sqrt(h.d2);
  return dot(p - h.point.q, n) < 0 ? -d : d;
}

SdfGrid sdf_grid_geometry(const Vec3d& lo, const Vec3d& hi, const SdfResolution& res) {
  const Vec3d e = hi - lo;
  const double longest = std::max({e.x, e.y, e.z});
  const int m = res.margin_cells;
  auto nodes_along = [&](double extent, double h) {
    return static_cast<std::uint32_t>(std::ceil(extent / h - 1e-9)) + 1 + 2 * m;
  };
  auto count = [&](double h) {
    return double(nodes_along(e.x, h)) * nodes_along(e.y, h) * nodes_along(e.z, h);
  };
  // Start from the cell that would fit the unpadded box exactly, then coarsen until the padded
  // one fits too (a flat box starts from its longest side instead of a zero volume).
  double h = std::max(std::cbrt(e.x * e.y * e.z / double(res.max_samples)), longest / 4096);
  while (count(h) > double(res.max_samples))
    h *= 1.01;
  SdfGrid g;
  g.cell = h;
  g.dims = {nodes_along(e.x, h), nodes_along(e.y, h), nodes_along(e.z, h)};
  const Vec3d c = (lo + hi) * 0.5;
  g.origin = c - Vec3d{(g.dims[0] - 1) * h, (g.dims[1] - 1) * h, (g.dims[2] - 1) * h} * 0.5;
  return g;
}

SdfGrid sample_sdf(const MeshSolid& mesh, const SdfResolution& res) {
  SdfGrid g = sdf_grid_geometry(mesh.lo, mesh.hi, res);
  const MeshDistance distance(mesh);
  const std::uint32_t nx = g.dims[0], ny = g.dims[1], nz = g.dims[2];
  g.values.resize(std::size_t(nx) * ny * nz);
  const long rows = long(ny) * nz;
  // Along a row the nearest triangle changes slowly: the previous node's seeds the search.
#pragma omp parallel for schedule(dynamic, 4)
  for (long r = 0; r < rows; ++r) {
    const auto j = static_cast<std::uint32_t>(r % ny), k = static_cast<std::uint32_t>(r / ny);
    std::uint32_t hint = 0;
    for (std::uint32_t i = 0; i < nx; ++i)
      g.values[g.index(i, j, k)] = distance(g.node(i, j, k), &hint);
  }
  return g;
}

} // namespace kf
