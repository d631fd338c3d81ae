#pragma once
// Which rank owns a point and which other ranks need it as a ghost, from the blocks a split
// domain is cut into (DESIGN §6; domain/Decomposition shares the blocks out). One evaluator for
// the host's decomposition and for the kernels that choose every particle's owner and ghost
// ranks at a rebuild (kernels/grid/RankSelection), so both backends decide alike. Positions are
// taken in double: a block edge is many particle spacings, and the host and the device then
// round alike.
#include "core/HostDevice.hpp"
#include "core/Vec3.hpp"

namespace kf {

/// A regular grid of cubic blocks of edge `edge` from `lo`, n[0] x n[1] x n[2] of them. A point
/// outside the box belongs to the nearest edge block: the edge blocks reach to infinity outward.
struct BlockGridView {
  Vec3d lo{0, 0, 0};
  double edge = 1;
  int n[3] = {1, 1, 1};

  KF_HD KF_INLINE int index(int i, int j, int k) const { return i + n[0] * (j + n[1] * k); }
  /// The block coordinate of x along axis d, clamped to the grid (NaN lands in block 0).
  KF_HD KF_INLINE int coord(const Vec3d& x, int d) const {
    const double u = ((&x.x)[d] - (&lo.x)[d]) / edge;
    return u >= 0 ? (u < n[d] ? static_cast<int>(u) : n[d] - 1) : 0;
  }
  KF_HD KF_INLINE int block_of(const Vec3d& x) const {
    return index(coord(x, 0), coord(x, 1), coord(x, 2));
  }
  /// Squared distance from x to block (c0, c1, c2)'s box (0 inside; edge blocks open outward).
  KF_HD KF_INLINE double distance2(const Vec3d& x, const int c[3]) const {
    double d2 = 0;
    for (int d = 0; d < 3; ++d) {
      const double u = (&x.x)[d] - (&lo.x)[d];
      const double a = c[d] * edge, z = (c[d] + 1) * edge;
      double out = 0;
      if (c[d] > 0 && u < a)
        out = a - u;
      else if (c[d] < n[d] - 1 && u > z)
        out = u - z;
      d2 += out * out;
    }
    return d2;
  }
};

/// Calls f(rank) for the owner of every block within `width` of x (distance to its box below
/// width) other than x's own block's owner; a rank may be named more than once. `reach`: how many
/// blocks the width spans (ceil(width / edge), at least 1). Along each axis only the blocks the
/// width reaches from x are looked at: most points touch no other block, a point near a face one,
/// near an edge three.
template <typename F>
KF_HD KF_INLINE void for_each_ghost_rank(const BlockGridView& g, const int* owner, const Vec3d& x,
                                         double width, int reach, F&& f) {
  int c[3], lo[3], hi[3];
  for (int d = 0; d < 3; ++d) {
    c[d] = g.coord(x, d);
    const double u = (&x.x)[d] - (&g.lo.x)[d] - c[d] * g.edge;
    lo[d] = c[d] - (u < width ? reach : 0);
    lo[d] = lo[d] < 0 ? 0 : lo[d];
    hi[d] = c[d] + (g.edge - u < width ? reach : 0);
    hi[d] = hi[d] > g.n[d] - 1 ? g.n[d] - 1 : hi[d];
  }
  if (lo[0] == hi[0] && lo[1] == hi[1] && lo[2] == hi[2])
    return;
  const int own = owner[g.index(c[0], c[1], c[2])];
  const double w2 = width * width;
  for (int k = lo[2]; k <= hi[2]; ++k)
    for (int j = lo[1]; j <= hi[1]; ++j)
      for (int i = lo[0]; i <= hi[0]; ++i) {
        const int o = owner[g.index(i, j, k)];
        const int b[3] = {i, j, k};
        if (o != own && g.distance2(x, b) < w2)
          f(o);
      }
}

} // namespace kf
