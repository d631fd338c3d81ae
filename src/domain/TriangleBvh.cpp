#include "domain/TriangleBvh.hpp"

#include <algorithm>
#include <limits>

namespace kf {

namespace {

/// Closest point of segment [a, b] to p, with the feature it is (the segment's edge or an end).
TriPoint closest_on_segment(const Vec3d& p, const Vec3d& a, const Vec3d& b, TriFeature edge,
                            TriFeature at_a, TriFeature at_b) {
  const Vec3d ab = b - a;
  const double len2 = norm2(ab);
  const double t = len2 > 0 ? dot(p - a, ab) / len2 : 0.0;
  if (t <= 0)
    return {a, at_a};
  if (t >= 1)
    return {b, at_b};
  return {a + ab * t, edge};
}

double box_distance2(const Vec3d& p, const Vec3d& lo, const Vec3d& hi) {
  const double dx = std::max({lo.x - p.x, 0.0, p.x - hi.x});
  const double dy = std::max({lo.y - p.y, 0.0, p.y - hi.y});
  const double dz = std::max({lo.z - p.z, 0.0, p.z - hi.z});
  return dx * dx + dy * dy + dz * dz;
}

Vec3d min3(const Vec3d& a, const Vec3d& b) {
  return {std::min(a.x, b.x), std::min(a.y, b.y), std::min(a.z, b.z)};
}
Vec3d max3(const Vec3d& a, const Vec3d& b) {
  return {std::max(a.x, b.x), std::max(a.y, b.y), std::max(a.z, b.z)};
}

} // namespace

TriPoint closest_point_on_triangle(const Vec3d& p, const Vec3d& a, const Vec3d& b, const Vec3d& c) {
  // Barycentric tests against the Voronoi regions of the vertices, then of the edges; what is
  // left projects into the interior. The d_i are projections of p's offsets onto the edges.
  const Vec3d ab = b - a, ac = c - a;
  const Vec3d ap = p - a;
  const double d1 = dot(ab, ap), d2 = dot(ac, ap);
  if (d1 <= 0 && d2 <= 0)
    return {a, TriFeature::VertexA};
  const Vec3d bp = p - b;
  const double d3 = dot(ab, bp), d4 = dot(ac, bp);
  if (d3 >= 0 && d4 <= d3)
    return {b, TriFeature::VertexB};
  const Vec3d cp = p - c;
  const double d5 = dot(ab, cp), d6 = dot(ac, cp);
  if (d6 >= 0 && d5 <= d6)
    return {c, TriFeature::VertexC};
  const double vc = d1 * d4 - d3 * d2; // barycentric weight of c, times twice the area squared
  if (vc <= 0 && d1 >= 0 && d3 <= 0)
    return {a + ab * (d1 / (d1 - d3)), TriFeature::EdgeAB};
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0)
    return {a + ac * (d2 / (d2 - d6)), TriFeature::EdgeCA};
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && d4 - d3 >= 0 && d5 - d6 >= 0)
    return {b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6))), TriFeature::EdgeBC};
  const double sum = va + vb + vc;
  if (!(sum > 0)) { // zero area: the nearest of the three edges
    TriPoint best =
        closest_on_segment(p, a, b, TriFeature::EdgeAB, TriFeature::VertexA, TriFeature::VertexB);
    for (const TriPoint& e :
         {closest_on_segment(p, b, c, TriFeature::EdgeBC, TriFeature::VertexB, TriFeature::VertexC),
          closest_on_segment(p, c, a, TriFeature::EdgeCA, TriFeature::VertexC,
                             TriFeature::VertexA)})
      if (norm2(e.q - p) < norm2(best.q - p))
        best = e;
    return best;
  }
  return {a + ab * (vb / sum) + ac * (vc / sum), TriFeature::Face};
}

TriangleBvh::TriangleBvh(const std::vector<Vec3d>& vertices, const std::vector<Triangle>& triangles)
    : x_(vertices), tri_(triangles) {
  const auto n = static_cast<std::uint32_t>(triangles.size());
  order_.resize(n);
  std::vector<Vec3d> centroids(n);
  for (std::uint32_t t = 0; t < n; ++t) {
    order_[t] = t;
    const auto& v = triangles[t];
    centroids[t] = (x_[v[0]] + x_[v[1]] + x_[v[2]]) * (1.0 / 3.0);
  }
  nodes_.reserve(n); // at most n / 2 leaves (each holds 2..4 triangles)
  if (n)
    build(0, n, centroids);
}

std::uint32_t TriangleBvh::build(std::uint32_t begin, std::uint32_t end,
                                 std::vector<Vec3d>& centroids) {
  constexpr std::uint32_t kLeaf = 4;
  const double inf = std::numeric_limits<double>::infinity();
  Vec3d lo{inf, inf, inf}, hi{-inf, -inf, -inf}, clo = lo, chi = hi;
  for (std::uint32_t i = begin; i < end; ++i) {
    const auto& v = tri_[order_[i]];
    for (int k = 0; k < 3; ++k) {
      lo = min3(lo, x_[v[k]]);
      hi = max3(hi, x_[v[k]]);
    }
    clo = min3(clo, centroids[order_[i]]);
    chi = max3(chi, centroids[order_[i]]);
  }
  const auto index = static_cast<std::uint32_t>(nodes_.size());
  nodes_.push_back({lo, hi, begin, end - begin});
  if (end - begin <= kLeaf)
    return index;
  // Median split along the centroids' widest axis: balanced, so the depth is log2(n / 4).
  const Vec3d ext = chi - clo;
  const int axis = ext.x >= ext.y && ext.x >= ext.z ? 0 : (ext.y >= ext.z ? 1 : 2);
  const std::uint32_t mid = begin + (end - begin) / 2;
  std::nth_element(order_.begin() + begin, order_.begin() + mid, order_.begin() + end,
                   [&](std::uint32_t s, std::uint32_t t) {
                     return (&centroids[s].x)[axis] < (&centroids[t].x)[axis];
                   });
  build(begin, mid, centroids); // the left child is index + 1
  const std::uint32_t right = build(mid, end, centroids);
  nodes_[index].first = right;
  nodes_[index].count = 0;
  return index;
}

void TriangleBvh::test(const Vec3d& p, std::uint32_t t, Hit& best) const {
  const auto& v = tri_[t];
  const TriPoint q = closest_point_on_triangle(p, x_[v[0]], x_[v[1]], x_[v[2]]);
  const double d2 = norm2(q.q - p);
  if (d2 < best.d2) {
    best.d2 = d2;
    best.triangle = t;
    best.point = q;
  }
}

TriangleBvh::Hit TriangleBvh::nearest(const Vec3d& p, std::uint32_t hint) const {
  Hit best;
  best.d2 = std::numeric_limits<double>::infinity();
  if (nodes_.empty())
    return best;
  test(p, hint < tri_.size() ? hint : 0, best);
  // Depth is about log2(n / 4) for median splits; 64 entries cover any mesh that fits in memory.
  std::uint32_t stack[64];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const Node& node = nodes_[stack[--top]];
    if (box_distance2(p, node.lo, node.hi) >= best.d2)
      continue;
    if (node.count) {
      for (std::uint32_t i = node.first; i < node.first + node.count; ++i)
        test(p, order_[i], best);
      continue;
    }
    const auto left = static_cast<std::uint32_t>(&node - nodes_.data()) + 1, right = node.first;
    const double dl = box_distance2(p, nodes_[left].lo, nodes_[left].hi);
    const double dr = box_distance2(p, nodes_[right].lo, nodes_[right].hi);
    // Push the farther child first so the nearer one is searched first and tightens the bound.
    const bool left_first = dl <= dr;
    const std::uint32_t near = left_first ? left : right, far = left_first ? right : left;
    const double dn = left_first ? dl : dr, df = left_first ? dr : dl;
    if (df < best.d2)
      stack[top++] = far;
    if (dn < best.d2)
      stack[top++] = near;
  }
  return best;
}

} // namespace kf
