#pragma once
// Uniform grid of cubic cells (edge = the largest interaction radius) and the neighbour loop every
// gather kernel uses. Particles are sorted by cell: rows of cells along x, the rows in Morton order
// of (y, z) (NeighbourGrid); `rank` maps a cell's linear index to its position in that order,
// where `start/end` hold the cell's particle range (0, 0 for an empty cell).
#include "core/HostDevice.hpp"
#include "core/Math.hpp"
#include "core/Vec3.hpp"

#include <cstdint>

namespace kf {

/// Most levels of sub-cell order a grid sorts by (NeighbourGrid).
constexpr int kMaxOrderLevels = 2;

template <typename T>
struct GridGeometry {
  Vec3<T> origin{};
  T cell = T(1);
  T inv_cell = T(1);
  int nx = 1, ny = 1, nz = 1;
  // The first cell's index on the whole grid this one is a window of (a rank's region,
  // NeighbourGrid::within): its cells are the whole grid's cells, numbered from there, so a
  // point's cell and sub-cell come out as on the whole grid (same origin, integers subtracted).
  int ox = 0, oy = 0, oz = 0;

  /// The same cells (origin, edge, counts and window offsets): grids whose cell indices agree.
  bool same_cells(const GridGeometry& o) const {
    return origin.x == o.origin.x && origin.y == o.origin.y && origin.z == o.origin.z &&
           cell == o.cell && nx == o.nx && ny == o.ny && nz == o.nz && ox == o.ox && oy == o.oy &&
           oz == o.oz;
  }
  KF_HD KF_INLINE std::uint32_t cells() const {
    return static_cast<std::uint32_t>(nx) * static_cast<std::uint32_t>(ny) *
           static_cast<std::uint32_t>(nz);
  }
  KF_HD KF_INLINE static int clampi(int v, int lo, int hi) {
    return v < lo ? lo : (v > hi ? hi : v);
  }
  /// Cell coordinates of a point; points outside the grid fall into the nearest edge cell.
  KF_HD KF_INLINE void coords(const Vec3<T>& x, int& ix, int& iy, int& iz) const {
    ix = clampi(static_cast<int>(kfloor((x.x - origin.x) * inv_cell)) - ox, 0, nx - 1);
    iy = clampi(static_cast<int>(kfloor((x.y - origin.y) * inv_cell)) - oy, 0, ny - 1);
    iz = clampi(static_cast<int>(kfloor((x.z - origin.z) * inv_cell)) - oz, 0, nz - 1);
  }
  /// Morton code (x lowest) of the sub-cell of x in cell (ix, iy, iz) when the cell is split
  /// into 2^levels a side (levels 0-2; points outside the grid take the nearest sub-cell).
  KF_HD KF_INLINE std::uint32_t sub_cell_code(const Vec3<T>& x, int ix, int iy, int iz,
                                              int levels) const {
    const int n = 1 << levels;
    const T scale = inv_cell * T(n);
    const int sx =
        clampi(static_cast<int>(kfloor((x.x - origin.x) * scale)) - (ix + ox) * n, 0, n - 1);
    const int sy =
        clampi(static_cast<int>(kfloor((x.y - origin.y) * scale)) - (iy + oy) * n, 0, n - 1);
    const int sz =
        clampi(static_cast<int>(kfloor((x.z - origin.z) * scale)) - (iz + oz) * n, 0, n - 1);
    std::uint32_t code = 0;
    for (int b = 0; b < levels; ++b)
      code |= ((std::uint32_t(sx) >> b & 1u) | (std::uint32_t(sy) >> b & 1u) << 1 |
               (std::uint32_t(sz) >> b & 1u) << 2)
              << (3 * b);
    return code;
  }
  /// The centre of cell (ix, iy, iz) of this grid.
  KF_HD KF_INLINE Vec3<T> centre(int ix, int iy, int iz) const {
    return {origin.x + (T(ix + ox) + T(0.5)) * cell, origin.y + (T(iy + oy) + T(0.5)) * cell,
            origin.z + (T(iz + oz) + T(0.5)) * cell};
  }
  KF_HD KF_INLINE std::uint32_t linear(int ix, int iy, int iz) const {
    return (static_cast<std::uint32_t>(iz) * static_cast<std::uint32_t>(ny) +
            static_cast<std::uint32_t>(iy)) *
               static_cast<std::uint32_t>(nx) +
           static_cast<std::uint32_t>(ix);
  }
};

/// Read-only view of one particle set's cell tables, passed by value into kernels.
template <typename T>
struct CellView {
  GridGeometry<T> geo;
  const std::uint32_t* rank = nullptr;  // linear cell -> rank (NeighbourGrid's cell order)
  const std::uint32_t* start = nullptr; // rank -> first particle
  const std::uint32_t* end = nullptr;   // rank -> one past last particle
  /// Cells searched on each side: the interaction radius is span cell edges. Cells of half the
  /// radius (span 2) test (5/2)^3 = 15.6 h^3 of candidates instead of 3^3 = 27 h^3.
  int span = 1;

  /// Whether the walk from x may meet a candidate: `occupied` is NeighbourGrid::occupied_around
  /// of this grid (per linear cell; null: assume so). A point of another set can skip its walk.
  KF_HD KF_INLINE bool may_find(const std::uint8_t* occupied, const Vec3<T>& x) const {
    if (!occupied)
      return true;
    int cx, cy, cz;
    geo.coords(x, cx, cy, cz);
    return occupied[geo.linear(cx, cy, cz)] != 0;
  }

  /// Calls row(c0, width) for each row along x of the (2 span + 1)^3 cells around x: the cells
  /// c0 .. c0 + width in rank order (consecutive along x). Stops when row returns true.
  template <typename F>
  KF_HD KF_INLINE void for_each_row(const Vec3<T>& x, F&& row) const {
    int cx, cy, cz;
    geo.coords(x, cx, cy, cz);
    for_each_row(cx, cx, cy, cz, row);
  }
  /// The same around the cells cx0 .. cx1 of the row (cy, cz): the rows of every cell within
  /// span of one of them, in the same (z, y) order, each from cx0 - span to cx1 + span.
  template <typename F>
  KF_HD KF_INLINE void for_each_row(int cx0, int cx1, int cy, int cz, F&& row) const {
    const int z0 = cz > span ? cz - span : 0, z1 = cz < geo.nz - 1 - span ? cz + span : geo.nz - 1;
    const int y0 = cy > span ? cy - span : 0, y1 = cy < geo.ny - 1 - span ? cy + span : geo.ny - 1;
    const int x0 = cx0 > span ? cx0 - span : 0,
              x1 = cx1 < geo.nx - 1 - span ? cx1 + span : geo.nx - 1;
    const std::uint32_t width = static_cast<std::uint32_t>(x1 - x0);
    for (int z = z0; z <= z1; ++z)
      for (int y = y0; y <= y1; ++y)
        if (row(rank[geo.linear(x0, y, z)], width))
          return;
  }

  /// Calls f(j) for every particle j in the (2 span + 1)^3 cells around x (a superset of the
  /// particles within span cell edges of x); f filters by distance itself. The cells of a row
  /// along x have consecutive ranks, so their particles are contiguous: one range per row.
  template <typename F>
  KF_HD KF_INLINE void for_each_candidate(const Vec3<T>& x, F&& f) const {
    for_each_candidate(x, 0u, 1u, f);
  }
  /// The same, shared by `stride` lanes: this one calls f for every stride-th candidate of each
  /// row from `lane` on (the lanes together visit each candidate once). Candidates, not rows:
  /// a knit sheet fills few of a point's rows, and rows split between lanes left most lanes
  /// idle (the whole pour took 27% longer on an H100).
  template <typename F>
  KF_HD KF_INLINE void for_each_candidate(const Vec3<T>& x, std::uint32_t lane,
                                          std::uint32_t stride, F&& f) const {
    for_each_row_range(x, [&](std::uint32_t lo, std::uint32_t hi) {
      for (std::uint32_t j = lo + lane; j < hi; j += stride)
        f(j);
    });
  }
  /// Calls range(lo, hi) with the particles [lo, hi) of each non-empty row around x, in the
  /// order for_each_candidate visits them.
  template <typename F>
  KF_HD KF_INLINE void for_each_row_range(const Vec3<T>& x, F&& range) const {
    int cx, cy, cz;
    geo.coords(x, cx, cy, cz);
    for_each_row_range(cx, cx, cy, cz, range);
  }
  /// The same around the cells cx0 .. cx1 of the row (cy, cz) (for_each_row).
  template <typename F>
  KF_HD KF_INLINE void for_each_row_range(int cx0, int cx1, int cy, int cz, F&& range) const {
    for_each_row(cx0, cx1, cy, cz, [&](std::uint32_t c0, std::uint32_t width) {
      // Empty cells read (0, 0); the row's range runs from its first non-empty cell's start
      // to its last non-empty cell's end.
      std::uint32_t lo = 0xFFFFFFFFu, hi = 0;
      for (std::uint32_t c = c0; c <= c0 + width; ++c) {
        const std::uint32_t s = start[c], e = end[c];
        if (s < e) {
          lo = lo < s ? lo : s;
          hi = e;
        }
      }
      if (lo < hi)
        range(lo, hi);
      return false;
    });
  }

  /// Whether any particle lies in the cells around x (for_each_candidate would call f).
  KF_HD KF_INLINE bool has_candidates(const Vec3<T>& x) const {
    bool any = false;
    for_each_row(x, [&](std::uint32_t c0, std::uint32_t width) {
      for (std::uint32_t c = c0; c <= c0 + width; ++c)
        if (start[c] < end[c])
          any = true;
      return any;
    });
    return any;
  }
};

} // namespace kf
