#pragma once
// Where an SPH particle's neighbours come from, for the evaluators: its fluid and boundary
// neighbours through one interface, either walked in the grids (SphCellWalk) or read from one
// list per particle holding both (SphList), built by SphListBuilder. Both call the fluid
// callback for the fluid grid's candidates in cell order, then the boundary callback for the
// boundary grid's, so a list built this step gives the same sums bit for bit.
#include "kernels/grid/NeighbourList.hpp"
#include "kernels/sph/Sph.hpp"

namespace kf {

/// Marks a list entry as a boundary particle's index (fluid counts stay below 2^31).
constexpr std::uint32_t kBoundaryEntry = 0x80000000u;

template <typename T>
struct SphCellWalk {
  CellView<T> cells;
  BoundaryNeighbours<T> b;
  template <typename FF, typename FB>
  KF_HD KF_INLINE void for_each_neighbour(std::size_t, const Vec3<T>& x, FF&& fluid,
                                          FB&& boundary) const {
    cells.for_each_candidate(x, fluid);
    if (b.around(x))
      b.cells.for_each_candidate(x, boundary);
  }
};

template <typename T>
struct SphList {
  ListView<T> list;
  template <typename FF, typename FB>
  KF_HD KF_INLINE void for_each_neighbour(std::size_t i, const Vec3<T>& x, FF&& fluid,
                                          FB&& boundary) const {
    list.for_each_neighbour(i, x, [&](std::uint32_t j) {
      if (j & kBoundaryEntry)
        boundary(j & ~kBoundaryEntry);
      else
        fluid(j);
    });
  }
};

/// Row i: the fluid particles, then the boundary particles, within sqrt(radius2) of x[i], in the
/// grids' candidate order. The lanes of a group test consecutive candidates of a row together
/// and append their hits in lane order (Lanes::count_below), so the order is the one-lane walk's:
/// a lone thread walking ~1,700 candidates with its own appends made the build cost as much as
/// two passes over the lists (measured, H100).
template <typename T>
struct SphListBuilder {
  const Vec3<T>* x;
  CellView<T> cells;
  BoundaryNeighbours<T> b;
  T radius2;
  ListSink out;

  KF_HD void operator()(std::size_t i, exec::Lanes g) const {
    const Vec3<T> xi = x[i];
    std::uint32_t c = 0;
    auto scan = [&](const Vec3<T>* y, const CellView<T>& cv, std::uint32_t tag) {
      cv.for_each_row_range(xi, [&](std::uint32_t lo, std::uint32_t hi) {
        for (std::uint32_t base = lo; base < hi; base += g.size) {
          const std::uint32_t j = base + g.lane;
          const bool hit = j < hi && norm2(xi - y[j]) < radius2;
          unsigned total;
          const std::uint32_t k = c + g.count_below(hit, &total);
          if (hit && k < out.capacity)
            *out.slot(i, k) = j | tag;
          c += total;
        }
      });
    };
    scan(x, cells, 0u);
    if (b.around(xi))
      scan(b.x, b.cells, kBoundaryEntry);
    if (g.lane == 0)
      out.count[i] = c;
  }
};

} // namespace kf
