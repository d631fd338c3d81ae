#include "support/KnitChecks.hpp"

#include <array>
#include <cstdlib>
#include <stdexcept>

namespace kf::test {

namespace {

struct P2 {
  double u, v;
};

/// Both checks walk rows and columns: a mesh piece has none, and a silent 0 would pass a test.
void require_grid(const KnitPieceLayout& L) {
  if (!L.grid)
    throw std::invalid_argument("knit check on a mesh piece: it needs a patch or tube grid");
}

double orient(P2 p, P2 q, P2 r) {
  return (q.u - p.u) * (r.v - p.v) - (q.v - p.v) * (r.u - p.u);
}

bool proper_crossing(P2 a, P2 b, P2 c, P2 d) {
  const double o1 = orient(a, b, c), o2 = orient(a, b, d), o3 = orient(c, d, a),
               o4 = orient(c, d, b);
  return ((o1 > 0 && o2 < 0) || (o1 < 0 && o2 > 0)) && ((o3 > 0 && o4 < 0) || (o3 < 0 && o4 > 0));
}

} // namespace

std::size_t profile_crossings(const std::vector<Vec3d>& x, const KnitPieceLayout& L, Vec3d a,
                              Vec3d b, int min_course_gap) {
  require_grid(L);
  std::size_t count = 0;
  for (int i = 0; i < L.nu; ++i) {
    // Segments (layer, j) from node j to j + 1 of column i.
    std::vector<std::array<P2, 2>> seg;
    std::vector<std::array<int, 2>> tag; // (layer, j)
    for (int layer = 0; layer < 3; ++layer)
      for (int j = 0; j + 1 < L.nv; ++j) {
        const Vec3d p = x[L.index(layer, i, j)], q = x[L.index(layer, i, j + 1)];
        seg.push_back({P2{dot(p, a), dot(p, b)}, P2{dot(q, a), dot(q, b)}});
        tag.push_back({layer, j});
      }
    for (std::size_t s = 0; s < seg.size(); ++s)
      for (std::size_t t = s + 1; t < seg.size(); ++t) {
        if (std::abs(tag[s][1] - tag[t][1]) < min_course_gap)
          continue;
        count += proper_crossing(seg[s][0], seg[s][1], seg[t][0], seg[t][1]);
      }
  }
  return count;
}

std::size_t layer_order_violations(const std::vector<Vec3d>& x, const std::vector<Vec3d>& rest,
                                   const KnitPieceLayout& L) {
  require_grid(L);
  auto side = [&](const std::vector<Vec3d>& p, int i, int j) {
    auto at = [&](int layer, int ii, int jj) {
      if (L.periodic_u)
        ii = (ii + L.nu) % L.nu;
      return p[L.index(layer, ii, jj)];
    };
    const Vec3d n = cross(at(1, i + 1, j) - at(1, i - 1, j), at(1, i, j + 1) - at(1, i, j - 1));
    return dot(at(0, i, j) - at(2, i, j), n);
  };
  std::size_t bad = 0;
  const int i0 = L.periodic_u ? 0 : 1, i1 = L.periodic_u ? L.nu : L.nu - 1;
  for (int j = 1; j + 1 < L.nv; ++j)
    for (int i = i0; i < i1; ++i)
      bad += (side(x, i, j) > 0) != (side(rest, i, j) > 0);
  return bad;
}

namespace {
template <typename T>
std::vector<Vec3d> points_of(const std::vector<T>& flat) {
  std::vector<Vec3d> p(flat.size() / 3);
  for (std::size_t i = 0; i < p.size(); ++i)
    p[i] = {double(flat[3 * i]), double(flat[3 * i + 1]), double(flat[3 * i + 2])};
  return p;
}
} // namespace

std::vector<Vec3d> as_points(const std::vector<double>& flat) {
  return points_of(flat);
}
std::vector<Vec3d> as_points(const std::vector<float>& flat) {
  return points_of(flat);
}

Scene knit_only_scene(const std::string& name) {
  Scene s;
  s.name = name;
  s.modules = {Module::Knit};
  s.domain.min = {-2, -2, -2};
  s.domain.max = {2, 2, 2};
  s.output.enabled = false;
  s.precision = Precision::Double;
  return s;
}

} // namespace kf::test
