#include "domain/Yarns.hpp"

#include "kernels/knit/Stitch_K.hpp"

#include <algorithm>

namespace kf {

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

/// Bonding point t_{k+1} (k = 0..11) of cell (i, j); Middle is halfway between the knit and the
/// purl point (on the middle layer of a flat patch).
Vec3d bonding(const std::vector<Vec3d>& x, const KnitPieceLayout& L, int i, int j, Side side,
              int k) {
  const int i1 = L.periodic_u ? (i + 1) % L.nu : i + 1;
  const Vec3d m[4] = {x[L.index(0, i, j)], x[L.index(0, i1, j)], x[L.index(0, i, j + 1)],
                      x[L.index(0, i1, j + 1)]};
  const Vec3d mb[4] = {x[L.index(2, i, j)], x[L.index(2, i1, j)], x[L.index(2, i, j + 1)],
                       x[L.index(2, i1, j + 1)]};
  if (side == Side::Middle)
    return (bonding_point(k, m, mb, false) + bonding_point(k, m, mb, true)) * 0.5;
  return bonding_point(k, m, mb, side == Side::Purl);
}

void push_unique(std::vector<Vec3d>& y, const Vec3d& p) {
  if (y.empty() || norm2(y.back() - p) > 0)
    y.push_back(p);
}

} // namespace

std::vector<std::vector<Vec3d>> yarn_bonding_points(const std::vector<Vec3d>& x,
                                                    const KnitPieceLayout& L,
                                                    const std::vector<std::string>& chart) {
  const int cu = L.periodic_u ? L.nu : L.nu - 1, cv = L.nv - 1;
  std::vector<std::vector<Vec3d>> yarns;
  if (cu < 1 || cv < 1)
    return yarns;
  // Eq. 1 gives the stockinette stitch; a purl stitch mirrors it through the thickness. Where a
  // loop passes through the loop below decides the depth of both: the old loop's head (t5 t6,
  // t10 t9) and the new loop's arc (t1..t4) take the side of the stitch above, the old loop's
  // lower legs (t7 t8, t12 t11) its own side. Where the two stitches differ (garter, seed), the
  // arc's dip (t2 t3) moves to the middle layer: on the back or front layer it would cut through
  // the old legs, which then lie on the same layer.
  for (int j = 0; j <= cv; ++j) {
    std::vector<Vec3d> y;
    for (int i = 0; i < cu; ++i) {
      const Side own = side_of(is_purl(chart, i, j)), above = side_of(is_purl(chart, i, j + 1));
      if (j < cv) { // left leg down: head t5 t6, then t7 (t8 is the arc's t1, or the cast-on edge)
        for (int k : {4, 5})
          push_unique(y, bonding(x, L, i, j, above, k));
        for (int k : {6, 7})
          push_unique(y, bonding(x, L, i, j, own, k));
      }
      if (j > 0) { // the head arc of the cell below: t1 t2 t3 t4
        const Side below = side_of(is_purl(chart, i, j - 1));
        const Side dip = below == own ? own : Side::Middle;
        push_unique(y, bonding(x, L, i, j - 1, own, 0));
        push_unique(y, bonding(x, L, i, j - 1, dip, 1));
        push_unique(y, bonding(x, L, i, j - 1, dip, 2));
        push_unique(y, bonding(x, L, i, j - 1, own, 3));
        const int next = L.periodic_u ? (i + 1) % cu : i + 1;
        if (j == cv && next < cu && is_purl(chart, next, j) != is_purl(chart, i, j)) {
          // Bind-off between a knit and a purl stitch: the yarn below crosses the thickness at
          // this wale's top corner, so this one crosses below it, mid-thickness at v = 5/6.
          const int i1 = L.periodic_u ? (i + 1) % L.nu : i + 1;
          auto at = [&](int layer) {
            return x[L.index(layer, i1, j - 1)] * (1 / 6.) + x[L.index(layer, i1, j)] * (5 / 6.);
          };
          push_unique(y, (at(0) + at(2)) * 0.5);
        }
      }
      if (j < cv) { // right leg up: t12 t11, then the head t10 t9
        for (int k : {11, 10})
          push_unique(y, bonding(x, L, i, j, own, k));
        for (int k : {9, 8})
          push_unique(y, bonding(x, L, i, j, above, k));
      }
    }
    if (L.periodic_u && !y.empty())
      push_unique(y, y.front()); // a tube's course closes on itself
    yarns.push_back(std::move(y));
  }
  return yarns;
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
