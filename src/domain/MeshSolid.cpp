#include "domain/MeshSolid.hpp"

#include "core/Error.hpp"

#include <algorithm>
#include <cmath>
#include <initializer_list>
#include <limits>
#include <string_view>

namespace kf {

namespace {

/// One triangle's use of an edge: the edge's vertices in increasing order as key, and whether
/// the triangle runs it in that order.
struct EdgeUse {
  std::uint64_t key;
  std::uint32_t triangle;
  bool forward;
};

/// The parts concatenated (appended one by one: GCC 12 warns, -Wrestrict, on chains of +).
std::string cat(std::initializer_list<std::string_view> parts) {
  std::string out;
  for (std::string_view p : parts)
    out += p;
  return out;
}

std::string vertex_pair(std::uint64_t key) {
  // OBJ numbers vertices from 1.
  return cat(
      {"(", std::to_string((key >> 32) + 1), ", ", std::to_string((key & 0xFFFFFFFFu) + 1), ")"});
}

} // namespace

MeshSolid make_mesh_solid(const io::ObjMesh& obj, double scale, const Vec3d& translate) {
  const std::string name = cat({"mesh '", obj.source, "'"});
  auto line_of = [&](std::size_t face) {
    return cat({obj.source, ":", std::to_string(obj.face_line[face])});
  };
  if (obj.faces() == 0)
    throw Error(cat({name, " has no faces (f records)"}));
  for (std::size_t f = 0; f < obj.faces(); ++f) {
    const auto v = obj.face(f);
    for (std::size_t i = 0; i < v.size(); ++i)
      for (std::size_t j = i + 1; j < v.size(); ++j)
        if (v[i] == v[j])
          throw Error(cat({name, ": the face on ", line_of(f), " uses vertex ",
                           std::to_string(v[i] + 1), " twice"}));
  }

  const std::vector<io::ObjTriangle> tris = io::fan_triangles(obj);
  std::vector<EdgeUse> uses;
  uses.reserve(3 * tris.size());
  for (std::uint32_t t = 0; t < tris.size(); ++t)
    for (int k = 0; k < 3; ++k) {
      const std::uint64_t a = tris[t].v[k], b = tris[t].v[(k + 1) % 3];
      uses.push_back({std::min(a, b) << 32 | std::max(a, b), t, a < b});
    }
  std::sort(uses.begin(), uses.end(), [](const EdgeUse& x, const EdgeUse& y) {
    return x.key != y.key ? x.key < y.key : x.triangle < y.triangle;
  });
  for (std::size_t i = 0; i < uses.size();) {
    std::size_t j = i;
    while (j < uses.size() && uses[j].key == uses[i].key)
      ++j;
    const std::string edge = cat({"edge ", vertex_pair(uses[i].key)});
    const std::size_t count = j - i;
    if (count == 1)
      throw Error(cat({name, " is not closed: ", edge, " belongs to 1 face (",
                       line_of(tris[uses[i].triangle].face), ")"}));
    if (count > 2) {
      std::string lines;
      for (std::size_t k = i; k < j; ++k)
        lines += cat({k == i ? "" : ", ", line_of(tris[uses[k].triangle].face)});
      throw Error(cat({name, " is not a manifold: ", edge, " belongs to ", std::to_string(count),
                       " faces (", lines, ")"}));
    }
    if (uses[i].forward == uses[i + 1].forward)
      throw Error(cat({name, " is not consistently oriented: ", edge,
                       " runs the same way in its faces on ", line_of(tris[uses[i].triangle].face),
                       " and ", line_of(tris[uses[i + 1].triangle].face),
                       " (faces sharing an edge must list it in opposite orders)"}));
    i = j;
  }

  MeshSolid m;
  m.source = obj.source;
  m.vertices.reserve(obj.vertices.size());
  for (const Vec3d& x : obj.vertices)
    m.vertices.push_back(x * scale + translate);
  const double inf = std::numeric_limits<double>::infinity();
  m.lo = {inf, inf, inf};
  m.hi = {-inf, -inf, -inf};
  for (const auto& t : tris)
    for (std::uint32_t v : t.v) { // the box of the vertices in use (stray ones do not count)
      const Vec3d& x = m.vertices[v];
      m.lo = {std::min(m.lo.x, x.x), std::min(m.lo.y, x.y), std::min(m.lo.z, x.z)};
      m.hi = {std::max(m.hi.x, x.x), std::max(m.hi.y, x.y), std::max(m.hi.z, x.z)};
    }
  // Enclosed volume by the divergence theorem, about the box centre to limit cancellation.
  const Vec3d c = (m.lo + m.hi) * 0.5;
  double six_v = 0;
  m.triangles.reserve(tris.size());
  for (const auto& t : tris) {
    m.triangles.push_back(t.v);
    six_v += dot(m.vertices[t.v[0]] - c, cross(m.vertices[t.v[1]] - c, m.vertices[t.v[2]] - c));
  }
  const Vec3d e = m.hi - m.lo;
  const double box = e.x * e.y * e.z;
  if (!(std::fabs(six_v) / 6 > 1e-9 * box))
    throw Error(cat({name, " encloses no volume (its faces are flat or cancel out)"}));
  if (six_v < 0) // wound inward throughout: turn it outward
    for (auto& t : m.triangles)
      std::swap(t[1], t[2]);
  m.volume = std::fabs(six_v) / 6;
  return m;
}

} // namespace kf
