#include "render/SolidMeshes.hpp"

#include "core/Error.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>
#include <vector>

namespace kf::render {

namespace {

/// One flat triangle, counter-clockwise as given.
void add_triangle(SurfaceMesh& m, const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c) {
  const glm::dvec3 n = glm::cross(b - a, c - a);
  const double len = glm::length(n);
  if (!(len > 0))
    return; // a degenerate triangle covers nothing
  const auto first = std::uint32_t(m.position.size());
  for (const glm::dvec3& p : {a, b, c}) {
    m.position.emplace_back(p);
    m.normal.emplace_back(n / len);
  }
  m.index.insert(m.index.end(), {first, first + 1, first + 2});
}

/// Unit u, v in the plane of unit normal n, u then v counter-clockwise seen from its front.
std::pair<glm::dvec3, glm::dvec3> plane_basis(const glm::dvec3& n) {
  const glm::dvec3 u = glm::normalize(
      glm::cross(n, std::abs(n.z) < 0.9 ? glm::dvec3(0, 0, 1) : glm::dvec3(1, 0, 0)));
  return {u, glm::cross(n, u)};
}

/// The box's corner k: bit 0 x, bit 1 y, bit 2 z (hi where set).
glm::dvec3 box_corner(const glm::dvec3& lo, const glm::dvec3& hi, int k) {
  return {k & 1 ? hi.x : lo.x, k & 2 ? hi.y : lo.y, k & 4 ? hi.z : lo.z};
}

// Each face's corners counter-clockwise seen from outside, in the order x-, x+, y-, y+, z-, z+.
constexpr int kBoxFaces[6][4] = {{0, 4, 6, 2}, {1, 3, 7, 5}, {0, 1, 5, 4},
                                 {2, 6, 7, 3}, {0, 2, 3, 1}, {4, 5, 7, 6}};

} // namespace

SurfaceMesh box_mesh(const glm::dvec3& lo, const glm::dvec3& hi) {
  SurfaceMesh m;
  for (const auto& f : kBoxFaces) {
    add_triangle(m, box_corner(lo, hi, f[0]), box_corner(lo, hi, f[1]), box_corner(lo, hi, f[2]));
    add_triangle(m, box_corner(lo, hi, f[0]), box_corner(lo, hi, f[2]), box_corner(lo, hi, f[3]));
  }
  return m;
}

SurfaceMesh box_inside(const glm::dvec3& lo, const glm::dvec3& hi,
                       const std::array<bool, 6>& faces) {
  SurfaceMesh m;
  for (int f = 0; f < 6; ++f) {
    if (!faces[f])
      continue;
    const auto& q = kBoxFaces[f]; // reversed: counter-clockwise from inside
    add_triangle(m, box_corner(lo, hi, q[0]), box_corner(lo, hi, q[2]), box_corner(lo, hi, q[1]));
    add_triangle(m, box_corner(lo, hi, q[0]), box_corner(lo, hi, q[3]), box_corner(lo, hi, q[2]));
  }
  return m;
}

SurfaceMesh plane_mesh(const glm::dvec3& point, const glm::dvec3& normal, const glm::dvec3& centre,
                       double half) {
  const glm::dvec3 n = glm::normalize(normal);
  const glm::dvec3 c = centre - glm::dot(centre - point, n) * n;
  const auto [u, v] = plane_basis(n);
  SurfaceMesh m;
  const glm::dvec3 a = c - half * u - half * v, b = c + half * u - half * v,
                   d = c + half * u + half * v, e = c - half * u + half * v;
  add_triangle(m, a, b, d);
  add_triangle(m, a, d, e);
  return m;
}

SurfaceMesh plane_in_box(const glm::dvec3& point, const glm::dvec3& normal, const glm::dvec3& lo,
                         const glm::dvec3& hi) {
  const glm::dvec3 n = glm::normalize(normal);
  // Where the plane crosses each of the box's 12 edges (corners k and k | bit, bit not in k).
  std::vector<glm::dvec3> cut;
  for (int k = 0; k < 8; ++k)
    for (int bit : {1, 2, 4}) {
      if (k & bit)
        continue;
      const glm::dvec3 a = box_corner(lo, hi, k), b = box_corner(lo, hi, k | bit);
      const double da = glm::dot(a - point, n), db = glm::dot(b - point, n);
      if ((da < 0) == (db < 0) && da != 0 && db != 0)
        continue;
      if (da == db)
        continue; // the edge lies in the plane: its ends are met by the other edges
      cut.push_back(a + (b - a) * (da / (da - db)));
    }
  SurfaceMesh m;
  if (cut.size() < 3)
    return m;
  glm::dvec3 c(0);
  for (const glm::dvec3& p : cut)
    c += p;
  c /= double(cut.size());
  const auto [u, v] = plane_basis(n);
  auto angle = [&](const glm::dvec3& p) {
    return std::atan2(glm::dot(p - c, v), glm::dot(p - c, u));
  };
  std::sort(cut.begin(), cut.end(),
            [&](const glm::dvec3& a, const glm::dvec3& b) { return angle(a) < angle(b); });
  for (std::size_t k = 1; k + 1 < cut.size(); ++k) // a fan (a corner met twice adds nothing)
    add_triangle(m, cut[0], cut[k], cut[k + 1]);
  return m;
}

SurfaceMesh triangle_mesh(const std::vector<glm::dvec3>& vertices,
                          const std::vector<std::array<std::uint32_t, 3>>& triangles) {
  SurfaceMesh m;
  for (std::size_t t = 0; t < triangles.size(); ++t) {
    for (std::uint32_t i : triangles[t])
      if (i >= vertices.size())
        throw Error("render: triangle " + std::to_string(t) + " names vertex " + std::to_string(i) +
                    " of " + std::to_string(vertices.size()));
    add_triangle(m, vertices[triangles[t][0]], vertices[triangles[t][1]],
                 vertices[triangles[t][2]]);
  }
  return m;
}

void append(SurfaceMesh& whole, const SurfaceMesh& part) {
  const auto offset = std::uint32_t(whole.position.size());
  whole.position.insert(whole.position.end(), part.position.begin(), part.position.end());
  whole.normal.insert(whole.normal.end(), part.normal.begin(), part.normal.end());
  if (!whole.shade.empty() || !part.shade.empty()) {
    whole.shade.resize(offset, 1.0f);
    if (part.shade.empty())
      whole.shade.resize(whole.position.size(), 1.0f);
    else
      whole.shade.insert(whole.shade.end(), part.shade.begin(), part.shade.end());
  }
  for (std::uint32_t i : part.index)
    whole.index.push_back(offset + i);
}

} // namespace kf::render
