#include "domain/Yarns.hpp"

#include "kernels/knit/Stitch_K.hpp"

#include <algorithm>
#include <cstdint>
#include <map>
#include <utility>

namespace kf {

Vec3d stitch_colour(const std::vector<std::string>& colour_chart,
                    const std::map<char, Vec3d>& colours, int i, int j) {
  const std::string& row = colour_chart[static_cast<std::size_t>(j) % colour_chart.size()];
  return colours.at(row[static_cast<std::size_t>(i) % row.size()]);
}

bool is_purl(const std::vector<std::string>& chart, int i, int j) {
  const std::string& row = chart[static_cast<std::size_t>(j) % chart.size()];
  return row[static_cast<std::size_t>(i) % row.size()] == 'P';
}

namespace {

/// Which way a bonding point of a cell is mirrored.
enum class Side { Knit, Purl, Middle };

Side side_of(bool purl) {
  return purl ? Side::Purl : Side::Knit;
}

/// A stitch cell's corner points on the front (layer 0) and back (layer 2) layers, in the order of
/// Stitch_K's m: (i, j), (i + 1, j), (i, j + 1), (i + 1, j + 1).
struct StitchCell {
  std::array<std::uint32_t, 4> front, back;
};

StitchCell grid_cell(const KnitPieceLayout& L, int i, int j) {
  const int i1 = L.periodic_u ? (i + 1) % L.nu : i + 1;
  StitchCell c;
  for (int l : {0, 2}) {
    auto& p = l == 0 ? c.front : c.back;
    p = {L.index(l, i, j), L.index(l, i1, j), L.index(l, i, j + 1), L.index(l, i1, j + 1)};
  }
  return c;
}

/// A mesh quad (v0 v1 v2 v3 counter-clockwise seen from the front): v0 -> v1 is the course (u),
/// v0 -> v3 the wale (v) direction, as for a grid cell.
StitchCell quad_cell(const KnitPieceLayout& L, const std::array<std::uint32_t, 4>& q) {
  StitchCell c;
  for (int l : {0, 2}) {
    auto& p = l == 0 ? c.front : c.back;
    auto at = [&](std::uint32_t v) { return L.index(l, static_cast<int>(v), 0); };
    p = {at(q[0]), at(q[1]), at(q[3]), at(q[2])};
  }
  return c;
}

/// The knit points' positions and, optionally, a scalar carried along (saturation).
struct Source {
  const std::vector<Vec3d>& x;
  const std::vector<double>* s;
};

/// Bonding point t_{k+1} (k = 0..11) of a cell; Middle is halfway between the knit and the purl
/// point (on the middle layer of a flat patch). The scalar takes the same weights (they sum to 1).
YarnPoint bonding(const Source& src, const StitchCell& c, Side side, int k) {
  auto eval = [&](auto value) {
    const Vec3d m[4] = {value(c.front[0]), value(c.front[1]), value(c.front[2]), value(c.front[3])};
    const Vec3d mb[4] = {value(c.back[0]), value(c.back[1]), value(c.back[2]), value(c.back[3])};
    if (side == Side::Middle)
      return (bonding_point(k, m, mb, false) + bonding_point(k, m, mb, true)) * 0.5;
    return bonding_point(k, m, mb, side == Side::Purl);
  };
  YarnPoint p{eval([&](std::uint32_t i) { return src.x[i]; }), 0};
  if (src.s)
    p.s = eval([&](std::uint32_t i) { return Vec3d{(*src.s)[i], 0, 0}; }).x;
  return p;
}

void push_unique(std::vector<YarnPoint>& y, const YarnPoint& p) {
  if (y.empty() || norm2(y.back().x - p.x) > 0)
    y.push_back(p);
}

/// Grid pieces: one yarn per course, stitches K or P from the chart.
std::vector<std::vector<YarnPoint>> grid_yarns(const Source& x, const KnitPieceLayout& L,
                                               const std::vector<std::string>& chart) {
  const int cu = L.periodic_u ? L.nu : L.nu - 1, cv = L.nv - 1;
  std::vector<std::vector<YarnPoint>> yarns;
  if (cu < 1 || cv < 1)
    return yarns;
  // Eq. 1 gives the stockinette stitch; a purl stitch mirrors it through the thickness. Where a
  // loop passes through the loop below decides the depth of both: the old loop's head (t5 t6,
  // t10 t9) and the new loop's arc (t1..t4) take the side of the stitch above, the old loop's
  // lower legs (t7 t8, t12 t11) its own side. Where the two stitches differ (garter, seed), the
  // arc's dip (t2 t3) moves to the middle layer: on the back or front layer it would cut through
  // the old legs, which then lie on the same layer.
  for (int j = 0; j <= cv; ++j) {
    std::vector<YarnPoint> y;
    for (int i = 0; i < cu; ++i) {
      const std::size_t from = y.size();
      const Side own = side_of(is_purl(chart, i, j)), above = side_of(is_purl(chart, i, j + 1));
      if (j < cv) { // left leg down: head t5 t6, then t7 (t8 is the arc's t1, or the cast-on edge)
        for (int k : {4, 5})
          push_unique(y, bonding(x, grid_cell(L, i, j), above, k));
        for (int k : {6, 7})
          push_unique(y, bonding(x, grid_cell(L, i, j), own, k));
      }
      if (j > 0) { // the head arc of the cell below: t1 t2 t3 t4
        const Side below = side_of(is_purl(chart, i, j - 1));
        const Side dip = below == own ? own : Side::Middle;
        push_unique(y, bonding(x, grid_cell(L, i, j - 1), own, 0));
        push_unique(y, bonding(x, grid_cell(L, i, j - 1), dip, 1));
        push_unique(y, bonding(x, grid_cell(L, i, j - 1), dip, 2));
        push_unique(y, bonding(x, grid_cell(L, i, j - 1), own, 3));
        const int next = L.periodic_u ? (i + 1) % cu : i + 1;
        if (j == cv && next < cu && is_purl(chart, next, j) != is_purl(chart, i, j)) {
          // Bind-off between a knit and a purl stitch: the yarn below crosses the thickness at
          // this wale's top corner, so this one crosses below it, mid-thickness at v = 5/6.
          const int i1 = L.periodic_u ? (i + 1) % L.nu : i + 1;
          auto at = [&](int layer) {
            const std::uint32_t a = L.index(layer, i1, j - 1), b = L.index(layer, i1, j);
            return YarnPoint{x.x[a] * (1 / 6.) + x.x[b] * (5 / 6.),
                             x.s ? (*x.s)[a] / 6. + (*x.s)[b] * (5 / 6.) : 0.0};
          };
          const YarnPoint lo = at(0), hi = at(2);
          push_unique(y, YarnPoint{(lo.x + hi.x) * 0.5, 0.5 * (lo.s + hi.s)});
        }
      }
      if (j < cv) { // right leg up: t12 t11, then the head t10 t9
        for (int k : {11, 10})
          push_unique(y, bonding(x, grid_cell(L, i, j), own, k));
        for (int k : {9, 8})
          push_unique(y, bonding(x, grid_cell(L, i, j), above, k));
      }
      for (std::size_t q = from; q < y.size(); ++q)
        y[q].wale = i;
    }
    if (L.periodic_u && !y.empty())
      push_unique(y, y.front()); // a tube's course closes on itself
    yarns.push_back(std::move(y));
  }
  return yarns;
}

/// Mesh pieces, all stockinette: a course is a strip of quads joined across their right edges
/// (v1 v2 of one is v0 v3 of the next, in the same frame); the quad above shares its bottom edge
/// with this one's top. Each quad's legs go into its strip's yarn with the head arc of the quad
/// below; arcs with no quad above form the strips' last yarns. A strip ends where the next quad's
/// frame is turned (an irregular vertex or a rotated face).
std::vector<std::vector<YarnPoint>> mesh_yarns(const Source& x, const KnitPieceLayout& L) {
  const auto& Q = L.quads;
  const std::size_t n = Q.size();
  constexpr std::int64_t kNone = -1;
  // Directed edge (a, b) of quad q's side e (0 bottom v0 v1, 1 right, 2 top, 3 left v3 v0).
  std::map<std::pair<std::uint32_t, std::uint32_t>, std::pair<std::int64_t, int>> owner;
  for (std::size_t q = 0; q < n; ++q)
    for (int e = 0; e < 4; ++e)
      owner[{Q[q][e], Q[q][(e + 1) % 4]}] = {std::int64_t(q), e};
  // The quad across side e of q if it continues q's frame (its side (e + 2) % 4 is the same edge).
  auto across = [&](std::size_t q, int e) {
    const auto it = owner.find({Q[q][(e + 1) % 4], Q[q][e]});
    return it != owner.end() && it->second.second == (e + 2) % 4 ? it->second.first : kNone;
  };
  std::vector<std::int64_t> right(n), left(n), below(n), above(n);
  for (std::size_t q = 0; q < n; ++q) {
    below[q] = across(q, 0);
    right[q] = across(q, 1);
    above[q] = across(q, 2);
    left[q] = across(q, 3);
  }
  const Side K = Side::Knit;
  std::vector<std::vector<YarnPoint>> yarns;
  // Strips through the quads for which `member` holds, from those whose left neighbour is not one
  // (open strips) and then around what is left (closed strips, which end where they began).
  auto strips = [&](auto member, auto add) {
    std::vector<char> done(n, 0);
    auto walk = [&](std::size_t start, bool closed) {
      std::vector<YarnPoint> y;
      std::int64_t q = std::int64_t(start);
      do {
        done[q] = 1;
        add(y, std::size_t(q));
        q = right[q];
      } while (q != kNone && member(std::size_t(q)) && !done[q]);
      if (closed && !y.empty())
        push_unique(y, y.front());
      yarns.push_back(std::move(y));
    };
    for (std::size_t q = 0; q < n; ++q)
      if (member(q) && !done[q] && (left[q] == kNone || !member(std::size_t(left[q]))))
        walk(q, false);
    for (std::size_t q = 0; q < n; ++q)
      if (member(q) && !done[q])
        walk(q, true);
  };
  auto arc = [&](std::vector<YarnPoint>& y, std::size_t q) {
    for (int k : {0, 1, 2, 3})
      push_unique(y, bonding(x, quad_cell(L, Q[q]), K, k));
  };
  strips([](std::size_t) { return true; },
         [&](std::vector<YarnPoint>& y, std::size_t q) {
           const StitchCell c = quad_cell(L, Q[q]);
           for (int k : {4, 5, 6, 7})
             push_unique(y, bonding(x, c, K, k));
           if (below[q] != kNone)
             arc(y, std::size_t(below[q]));
           for (int k : {11, 10, 9, 8})
             push_unique(y, bonding(x, c, K, k));
         });
  strips([&](std::size_t q) { return above[q] == kNone; }, arc);
  return yarns;
}

} // namespace

std::vector<std::vector<YarnPoint>> yarn_points(const std::vector<Vec3d>& x,
                                                const std::vector<double>* scalar,
                                                const KnitPieceLayout& L,
                                                const std::vector<std::string>& chart) {
  const Source src{x, scalar};
  return L.grid ? grid_yarns(src, L, chart) : mesh_yarns(src, L);
}

std::vector<std::vector<Vec3d>> yarn_bonding_points(const std::vector<Vec3d>& x,
                                                    const KnitPieceLayout& L,
                                                    const std::vector<std::string>& chart) {
  std::vector<std::vector<Vec3d>> out;
  for (const auto& y : yarn_points(x, nullptr, L, chart)) {
    std::vector<Vec3d> p;
    p.reserve(y.size());
    for (const YarnPoint& q : y)
      p.push_back(q.x);
    out.push_back(std::move(p));
  }
  return out;
}

YarnLines yarn_lines(const std::vector<std::vector<YarnPoint>>& yarns, int samples) {
  std::vector<std::vector<Vec3d>> pos(yarns.size());
  for (std::size_t y = 0; y < yarns.size(); ++y)
    for (const YarnPoint& q : yarns[y])
      pos[y].push_back(q.x);
  YarnLines out = yarn_lines(pos, samples);
  // The scalar along the same Catmull-Rom spans, never below zero (the spline may undershoot).
  for (std::size_t y = 0; y < yarns.size(); ++y) {
    const auto& p = yarns[y];
    const std::size_t n = p.size();
    if (n == 0)
      continue;
    auto at = [&](std::ptrdiff_t k) {
      return p[static_cast<std::size_t>(std::clamp<std::ptrdiff_t>(k, 0, std::ptrdiff_t(n) - 1))].s;
    };
    for (std::size_t s = 0; s + 1 < n; ++s)
      for (int q = 0; q < samples; ++q) {
        const Vec3d c = catmull_rom(Vec3d{at(std::ptrdiff_t(s) - 1), 0, 0}, Vec3d{p[s].s, 0, 0},
                                    Vec3d{p[s + 1].s, 0, 0}, Vec3d{at(std::ptrdiff_t(s) + 2), 0, 0},
                                    double(q) / samples);
        out.s.push_back(std::max(0.0, c.x));
        out.colour.push_back(2 * q < samples ? p[s].colour : p[s + 1].colour);
      }
    out.s.push_back(p.back().s);
    out.colour.push_back(p.back().colour);
  }
  return out;
}

YarnLines yarn_lines(const std::vector<std::vector<Vec3d>>& yarns, int samples) {
  YarnLines out;
  if (samples < 1)
    return out;
  for (std::size_t y = 0; y < yarns.size(); ++y) {
    const auto& p = yarns[y];
    if (p.empty())
      continue;
    const std::uint32_t first = static_cast<std::uint32_t>(out.x.size());
    const std::size_t n = p.size();
    auto at = [&](std::ptrdiff_t k) {
      return p[static_cast<std::size_t>(std::clamp<std::ptrdiff_t>(k, 0, std::ptrdiff_t(n) - 1))];
    };
    for (std::size_t s = 0; s + 1 < n; ++s)
      for (int q = 0; q < samples; ++q)
        out.x.push_back(catmull_rom(at(std::ptrdiff_t(s) - 1), p[s], p[s + 1],
                                    at(std::ptrdiff_t(s) + 2), double(q) / samples));
    out.x.push_back(p.back());
    const std::uint32_t end = static_cast<std::uint32_t>(out.x.size());
    for (std::uint32_t i = first; i < end; ++i) {
      out.yarn.push_back(static_cast<std::uint32_t>(y));
      out.segment.push_back({i, i + 1 < end ? i + 1 : i});
    }
  }
  return out;
}

} // namespace kf
