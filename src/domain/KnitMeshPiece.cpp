#include "domain/KnitMeshPiece.hpp"

#include "core/Error.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <set>
#include <sstream>

namespace kf {

namespace {

std::uint64_t edge_key(std::uint32_t a, std::uint32_t b) {
  return std::uint64_t(std::min(a, b)) << 32 | std::max(a, b);
}

/// One quad's use of an edge: whether it runs the edge from the smaller vertex index.
struct EdgeUse {
  std::uint64_t key;
  std::uint32_t quad;
  bool forward;
};

/// Throws kf::Error("mesh 'SOURCE' ...") built from the streamed parts.
template <typename... Parts>
[[noreturn]] void fail(const std::string& source, const Parts&... parts) {
  std::ostringstream os;
  os << "mesh '" << source << "'";
  (os << ... << parts);
  throw Error(os.str());
}

/// The vertex's corners (quad, position in it) walked around the vertex: each next corner shares
/// the edge to the previous corner's `next` vertex. Returns false when the quads form more than one
/// fan (they meet only at the vertex), which leaves the ring and the normal ill-defined.
bool walk_fan(const std::vector<std::array<std::uint32_t, 4>>& quads,
              const std::vector<std::array<std::uint32_t, 2>>& corners,
              std::vector<std::uint32_t>& ring, bool& boundary) {
  auto next = [&](const std::array<std::uint32_t, 2>& c) { return quads[c[0]][(c[1] + 1) % 4]; };
  auto prev = [&](const std::array<std::uint32_t, 2>& c) { return quads[c[0]][(c[1] + 3) % 4]; };
  // Orientation is consistent, so each neighbour is some corner's `next` at most once and some
  // corner's `prev` at most once.
  auto with_prev = [&](std::uint32_t w) -> int {
    for (std::size_t c = 0; c < corners.size(); ++c)
      if (prev(corners[c]) == w)
        return int(c);
    return -1;
  };
  auto with_next = [&](std::uint32_t w) -> int {
    for (std::size_t c = 0; c < corners.size(); ++c)
      if (next(corners[c]) == w)
        return int(c);
    return -1;
  };
  // A fan with a boundary starts at the corner whose `prev` edge has no quad before it.
  int start = 0;
  boundary = false;
  for (std::size_t c = 0; c < corners.size(); ++c)
    if (with_next(prev(corners[c])) < 0) {
      start = int(c);
      boundary = true;
      break;
    }
  ring.clear();
  if (boundary)
    ring.push_back(prev(corners[start]));
  std::size_t visited = 0;
  for (int c = start; c >= 0 && visited < corners.size();) {
    ++visited;
    ring.push_back(next(corners[c]));
    c = with_prev(next(corners[c]));
    if (c == start)
      break;
  }
  return visited == corners.size();
}

} // namespace

KnitQuadMesh make_knit_quad_mesh(const io::ObjMesh& obj, double scale, const Vec3d& translate) {
  const std::string& src = obj.source;
  auto line_of = [&](std::size_t face) { return src + ":" + std::to_string(obj.face_line[face]); };
  if (obj.faces() == 0)
    fail(src, " has no faces (f records)");
  KnitQuadMesh m;
  m.source = src;
  for (std::size_t f = 0; f < obj.faces(); ++f) {
    const auto v = obj.face(f);
    if (v.size() != 4)
      fail(src, " is not a quad mesh: the face on ", line_of(f), " has ", v.size(),
           " vertices (a knitted piece needs quads)");
    for (std::size_t i = 0; i < 4; ++i)
      for (std::size_t j = i + 1; j < 4; ++j)
        if (v[i] == v[j])
          fail(src, ": the face on ", line_of(f), " uses vertex ", v[i] + 1, " twice");
    m.quads.push_back({v[0], v[1], v[2], v[3]});
  }

  // Edges: at most two quads each, running it in opposite directions (a manifold with boundary,
  // one front side throughout).
  std::vector<EdgeUse> uses;
  for (std::uint32_t q = 0; q < m.quads.size(); ++q)
    for (int k = 0; k < 4; ++k) {
      const std::uint32_t a = m.quads[q][k], b = m.quads[q][(k + 1) % 4];
      uses.push_back({edge_key(a, b), q, a < b});
    }
  std::sort(uses.begin(), uses.end(), [](const EdgeUse& x, const EdgeUse& y) {
    return x.key != y.key ? x.key < y.key : x.quad < y.quad;
  });
  for (std::size_t i = 0; i < uses.size();) {
    std::size_t j = i;
    while (j < uses.size() && uses[j].key == uses[i].key)
      ++j;
    std::ostringstream edge;
    edge << "edge (" << (uses[i].key >> 32) + 1 << ", " << (uses[i].key & 0xFFFFFFFFu) + 1 << ")";
    if (j - i > 2) {
      std::string lines;
      for (std::size_t k = i; k < j; ++k)
        lines += (k == i ? "" : ", ") + line_of(uses[k].quad);
      fail(src, " is not a manifold: ", edge.str(), " belongs to ", j - i, " faces (", lines, ")");
    }
    if (j - i == 2 && uses[i].forward == uses[i + 1].forward)
      fail(src, " is not consistently oriented: ", edge.str(),
           " runs the same way in its faces on ", line_of(uses[i].quad), " and ",
           line_of(uses[i + 1].quad), " (faces sharing an edge must list it in opposite orders)");
    i = j;
  }

  const std::size_t n = obj.vertices.size();
  for (const Vec3d& x : obj.vertices)
    m.vertices.push_back(x * scale + translate);
  // Quad normals from the diagonals (exact for planar quads, the mean plane's for warped ones).
  std::vector<std::vector<std::array<std::uint32_t, 2>>> corners(n);
  std::vector<Vec3d> quad_normal;
  for (std::uint32_t q = 0; q < m.quads.size(); ++q) {
    const auto& v = m.quads[q];
    const Vec3d c = cross(m.vertices[v[2]] - m.vertices[v[0]], m.vertices[v[3]] - m.vertices[v[1]]);
    double shortest = std::numeric_limits<double>::infinity();
    for (int k = 0; k < 4; ++k)
      shortest = std::min(shortest, norm(m.vertices[v[(k + 1) % 4]] - m.vertices[v[k]]));
    if (!(norm(c) > 0) || !(shortest > 0))
      fail(src, ": the face on ", line_of(q), " is degenerate (zero area or a side of length 0)");
    quad_normal.push_back(c * (1.0 / norm(c)));
    for (std::uint32_t k = 0; k < 4; ++k)
      corners[v[k]].push_back({q, k});
  }

  m.normals.assign(n, Vec3d{0, 0, 0});
  m.boundary.assign(n, 0);
  const double inf = std::numeric_limits<double>::infinity();
  m.lo = {inf, inf, inf};
  m.hi = {-inf, -inf, -inf};
  std::vector<std::uint32_t> ring;
  for (std::size_t v = 0; v < n; ++v) {
    if (corners[v].empty())
      fail(src, ": vertex ", v + 1, " belongs to no face (every vertex of a knitted piece is a ",
           "stitch of some quad)");
    bool boundary = false;
    if (!walk_fan(m.quads, corners[v], ring, boundary))
      fail(src, " is not a manifold at vertex ", v + 1,
           ": its faces form separate fans that meet only there");
    m.boundary[v] = boundary;
    m.ring.insert(m.ring.end(), ring.begin(), ring.end());
    m.ring_start.push_back(static_cast<std::uint32_t>(m.ring.size()));
    Vec3d sum{0, 0, 0};
    for (const auto& c : corners[v])
      sum += quad_normal[c[0]];
    // Quads folded back onto each other cancel: no side is the front there.
    if (!(norm(sum) > 1e-9 * double(corners[v].size())))
      fail(src, ": the normal at vertex ", v + 1, " is undefined (its faces' normals cancel)");
    m.normals[v] = sum * (1.0 / norm(sum));
    const Vec3d& x = m.vertices[v];
    m.lo = {std::min(m.lo.x, x.x), std::min(m.lo.y, x.y), std::min(m.lo.z, x.z)};
    m.hi = {std::max(m.hi.x, x.x), std::max(m.hi.y, x.y), std::max(m.hi.z, x.z)};
  }
  return m;
}

std::shared_ptr<const KnitQuadMesh> load_knit_quad_mesh(const std::string& path, double scale,
                                                        const Vec3d& translate) {
  return std::make_shared<const KnitQuadMesh>(
      make_knit_quad_mesh(io::read_obj(path), scale, translate));
}

KnitPieceLayout append_mesh_piece(const KnitPiece& piece, const Scene::Knit& mat,
                                  std::uint16_t piece_index, KnitMesh& mesh) {
  const KnitQuadMesh& q = *piece.mesh;
  const std::vector<Vec3d>& x = q.vertices; // the middle layer
  const std::size_t n = x.size();
  const double half_t = 0.5 * mat.thickness;
  KnitPieceLayout L;
  L.first = static_cast<std::uint32_t>(mesh.x.size());
  L.nu = static_cast<int>(n);
  L.nv = 1;
  L.grid = false;
  L.quads = q.quads;
  auto at = [&](int layer, std::uint32_t v) { return L.index(layer, static_cast<int>(v), 0); };

  // A vertex stands for a quarter of each of its quads (the patch's a b, halved on open edges).
  // Area from the diagonals: exact for planar quads.
  std::vector<double> area(n, 0);
  std::vector<int> n_corners(n, 0);
  for (const auto& v : q.quads) {
    const double a = 0.5 * norm(cross(x[v[2]] - x[v[0]], x[v[3]] - x[v[1]]));
    for (std::uint32_t k : v) {
      area[k] += 0.25 * a;
      ++n_corners[k];
    }
  }
  for (int layer = 0; layer < 3; ++layer)
    for (std::size_t v = 0; v < n; ++v) {
      mesh.x.push_back(x[v] + q.normals[v] * (half_t * (1 - layer))); // 0 front, 2 back
      mesh.v.push_back(piece.velocity);
      mesh.m.push_back(mat.mass_per_area * area[v] / 3.0);
      mesh.layer.push_back(static_cast<std::uint8_t>(layer));
      mesh.piece.push_back(piece_index);
    }
  auto spring = [&](std::uint32_t i, std::uint32_t j, double k, SpringKind kind) {
    knit_build::add_spring(mesh, i, j, k, kind, mat.damping_ratio);
  };

  // Each edge's length a and the width of fabric it carries: per adjacent quad half the mean of
  // the quad's two other sides (the patch's b, b/2 on an open edge). All layers share the middle
  // layer's spacings, as on the patch.
  struct Edge {
    std::uint32_t a, b;
    double length, width;
  };
  std::map<std::uint64_t, Edge> edges;
  auto side = [&](const std::array<std::uint32_t, 4>& v, int k) {
    return norm(x[v[(k + 1) % 4]] - x[v[k]]);
  };
  for (const auto& v : q.quads)
    for (int k = 0; k < 4; ++k) {
      Edge& e = edges
                    .try_emplace(edge_key(v[k], v[(k + 1) % 4]),
                                 Edge{v[k], v[(k + 1) % 4], side(v, k), 0.0})
                    .first->second;
      e.width += 0.5 * (0.5 * (side(v, (k + 1) % 4) + side(v, (k + 3) % 4)));
    }
  auto edge = [&](std::uint32_t a, std::uint32_t b) -> const Edge& {
    return edges.at(edge_key(a, b));
  };

  // Bend springs span two edges that continue through a vertex: on a grid, the edges two quads
  // apart around it (interior valence 4, or a boundary vertex with its two quads). Elsewhere:
  // interior valence 2m, the edges m apart (straight across); odd valence >= 5, the edges
  // (n - 1) / 2 apart both ways at half stiffness (each edge in two pairs, so its weight stays one
  // pair's); valence 3 none (the edges are neighbours in a quad, whose shear spring already joins
  // their ends); a boundary vertex with m quads, edges two apart ((0, 2), ..., (m - 2, m)).
  struct BendPair {
    std::uint32_t p, c, r;
    double weight;
  };
  std::vector<BendPair> bends;
  std::set<std::uint64_t> bent; // a pair of ends joined once, however many routes (small rings)
  for (std::uint32_t c = 0; c < n; ++c) {
    const std::size_t s = q.ring_size(c);
    auto add = [&](std::size_t i, std::size_t j, double w) {
      const std::uint32_t p = q.ring_at(c, i), r = q.ring_at(c, j);
      if (p != r && bent.insert(edge_key(p, r)).second)
        bends.push_back({p, c, r, w});
    };
    if (q.boundary[c]) {
      for (std::size_t i = 0; i + 2 < s; ++i)
        add(i, i + 2, 1.0);
    } else if (s % 2 == 0 && s >= 4) {
      for (std::size_t i = 0; i < s / 2; ++i)
        add(i, i + s / 2, 1.0);
    } else if (s % 2 == 1 && s >= 5) {
      for (std::size_t i = 0; i < s; ++i)
        add(i, (i + (s - 1) / 2) % s, 0.5);
    }
  }

  // The moduli are the whole fabric's; each of the three layers carries a third.
  for (int layer = 0; layer < 3; ++layer) {
    for (const auto& [key, e] : edges) // stretch: Y b / a
      spring(at(layer, e.a), at(layer, e.b), mat.stretch * e.width / e.length / 3,
             SpringKind::Stretch);
    if (mat.shear > 0)
      for (const auto& v : q.quads) { // both diagonals: G (a^2 + b^2) / (2 a b)
        const double a = 0.5 * (side(v, 0) + side(v, 2)), b = 0.5 * (side(v, 1) + side(v, 3));
        const double kd = mat.shear * (a * a + b * b) / (2 * a * b) / 3;
        spring(at(layer, v[0]), at(layer, v[2]), kd, SpringKind::Shear);
        spring(at(layer, v[1]), at(layer, v[3]), kd, SpringKind::Shear);
      }
    if (mat.bend > 0)
      for (const BendPair& bp : bends) { // B b / (2 a): the mean width over the span
        const Edge &e1 = edge(bp.c, bp.p), &e2 = edge(bp.c, bp.r);
        const double width = 0.5 * (e1.width + e2.width);
        spring(at(layer, bp.p), at(layer, bp.r),
               bp.weight * mat.bend * width / (e1.length + e2.length) / 3, SpringKind::Bend);
      }
  }
  // Between adjacent layers, as on the patch: straight springs from the compression modulus over
  // the vertex's area, diagonal ones to the twin's edge neighbours from the layer shear modulus.
  for (int layer = 0; layer < 2; ++layer)
    for (std::uint32_t v = 0; v < n; ++v) {
      const double A = area[v];
      spring(at(layer, v), at(layer + 1, v),
             (1 - knit_build::kVolumeCellShare) * mat.compression * A / half_t,
             SpringKind::VolumeStraight);
      if (mat.layer_shear <= 0)
        continue;
      for (std::size_t k = 0; k < q.ring_size(v); ++k) {
        const std::uint32_t w = q.ring_at(v, k);
        const double s = edge(v, w).length, l2 = s * s + half_t * half_t;
        spring(at(layer, v), at(layer + 1, w), mat.layer_shear * A * l2 / (2 * s * s * half_t),
               SpringKind::VolumeDiagonal);
      }
    }
  // Volume cells: the front and back point over each quad corner of its middle-layer twin, the
  // corner's sides ordered (next, previous) in the quad's winding so every front cell has a
  // positive volume. Together a vertex's cells carry kVolumeCellShare of its compression
  // stiffness, split evenly over its corners (the patch splits it over its quadrants).
  for (int layer = 0; layer < 3; layer += 2)
    for (const auto& v : q.quads)
      for (int k = 0; k < 4; ++k) {
        const std::uint32_t o = v[k], next = v[(k + 1) % 4], prev = v[(k + 3) % 4];
        const double kh =
            knit_build::kVolumeCellShare * mat.compression * area[o] / half_t / n_corners[o];
        knit_build::add_volume_cell(mesh, {at(layer, o), at(1, o), at(1, next), at(1, prev)}, kh);
      }
  return L;
}

} // namespace kf
