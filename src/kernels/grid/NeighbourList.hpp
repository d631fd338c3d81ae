#pragma once
// Per-particle lists of the neighbours within a radius, built from a NeighbourGrid once per step
// and read by every pass of that step (density, forces).
//
// Why: on the GPU the lanes of a warp walk their grid candidates together, and with ~15% of
// candidates in range some lane almost always has a neighbour, so the whole warp runs the pair
// code for every candidate. A list pays the candidate walk once, with a cheap body (append),
// and the passes then run the pair code only for real neighbours. Measured on an H100
// (docs/PERFORMANCE.md): density and forces get 1.6-1.8x faster, but a build every step costs
// more than that saves, so solver.neighbour_list is off by default; reusing a list over several
// steps (a skin) is what would make it pay.
#include "kernels/exec/Algorithms.hpp"
#include "kernels/grid/GridGeometry.hpp"

namespace kf {

/// Read-only view of the lists, passed by value into kernels. Particle i's neighbours are the
/// row list[i * capacity, i * capacity + count[i]). Rows, so that the build can write four
/// indices with one 16-byte store (ListBuilder); a particle's own row is then read through L1.
template <typename T>
struct ListView {
  const std::uint32_t* count = nullptr;
  const std::uint32_t* list = nullptr;
  std::size_t capacity = 0;

  /// Whether row i holds all its neighbours (build_for's rows may overflow).
  KF_HD KF_INLINE bool complete(std::size_t i) const { return count[i] <= capacity; }
  /// Calls f(j) for the neighbours of i found at build time, in the grid's candidate order.
  template <typename F>
  KF_HD KF_INLINE void for_each_neighbour(std::size_t i, const Vec3<T>& x, F&& f) const {
    for_each_neighbour(i, x, 0u, 1u, f);
  }
  /// The same shared by `stride` lanes: this one takes every stride-th from `lane` on.
  template <typename F>
  KF_HD KF_INLINE void for_each_neighbour(std::size_t i, const Vec3<T>&, std::uint32_t lane,
                                          std::uint32_t stride, F&& f) const {
    const std::uint32_t c = count[i];
    const std::uint32_t* row = list + i * capacity;
    for (std::uint32_t k = lane; k < c; k += stride)
      f(row[k]);
  }
};

/// The same interface over a cell grid: every candidate of the cells around x (f filters).
template <typename T>
struct CellNeighbours {
  CellView<T> cells;
  template <typename F>
  KF_HD KF_INLINE void for_each_neighbour(std::size_t, const Vec3<T>& x, F&& f) const {
    cells.for_each_candidate(x, f);
  }
};

/// Every candidate within the radius may pair (the SPH lists).
struct AnyPair {
  KF_HD KF_INLINE bool operator()(std::size_t, std::uint32_t) const { return true; }
};

namespace list_detail {

/// Writes four indices with one 16-byte store on the GPU (p is 16-byte aligned).
KF_HD KF_INLINE void store4(std::uint32_t* p, std::uint32_t a, std::uint32_t b, std::uint32_t c,
                            std::uint32_t d) {
#if defined(__CUDA_ARCH__)
  *reinterpret_cast<uint4*>(p) = make_uint4(a, b, c, d);
#else
  p[0] = a;
  p[1] = b;
  p[2] = c;
  p[3] = d;
#endif
}

/// Appends i's neighbours while they fit; counts all of them (a count over the capacity marks
/// an overflow). Neighbours are held in registers and written four at a time: lanes of a warp
/// find neighbours at different candidates, so single-index stores each became their own
/// memory transaction, and the build cost 2.5x a density pass (measured).
template <typename T, typename Pred>
struct ListBuilder {
  const Vec3<T>* q;            // query points
  const Vec3<T>* x;            // candidates, in `cells`' order
  const std::uint32_t* active; // nullptr: every query point; else those with active[i] != 0
  CellView<T> cells;
  T radius2;
  std::size_t capacity; // a multiple of 4
  std::uint32_t* count;
  std::uint32_t* list;
  Pred keep; // keep(i, j): whether candidate j may pair with query i at all

  KF_HD void operator()(std::size_t i) const {
    if (active && !active[i]) {
      count[i] = 0;
      return;
    }
    const Vec3<T> xi = q[i];
    std::uint32_t c = 0, b0 = 0, b1 = 0, b2 = 0;
    std::uint32_t* row = list + i * capacity;
    cells.for_each_candidate(xi, [&](std::uint32_t j) {
      if (!(norm2(xi - x[j]) < radius2) || !keep(i, j))
        return;
      switch (c & 3u) {
      case 0:
        b0 = j;
        break;
      case 1:
        b1 = j;
        break;
      case 2:
        b2 = j;
        break;
      default:
        if (c < capacity)
          store4(row + (c - 3), b0, b1, b2, j);
      }
      ++c;
    });
    // The last 1-3 neighbours.
    const std::uint32_t tail = c & ~3u;
    if (tail < capacity) {
      if (tail + 0 < c)
        row[tail + 0] = b0;
      if (tail + 1 < c)
        row[tail + 1] = b1;
      if (tail + 2 < c)
        row[tail + 2] = b2;
    }
    count[i] = c;
  }
};

} // namespace list_detail

template <typename T>
class NeighbourList {
public:
  explicit NeighbourList(exec::Backend b);

  /// Lists, for each of the n points x (sorted as `cells` describes), every j with
  /// |x_i - x_j|^2 < radius2 (i itself included), in the order the cell walk meets them. The
  /// capacity grows (and the build repeats) until the densest particle fits.
  void build(const exec::Exec& ex, const Vec3<T>* x, std::size_t n, const CellView<T>& cells,
             T radius2);
  /// Lists, for each of n query points q (the inactive ones, active[i] == 0, get none), the
  /// candidates j of `cells` (positions x) with |q_i - x_j|^2 < radius2, in the order the cell
  /// walk meets them. Fixed capacity and no read on the host: a count over the capacity marks a
  /// row that overflowed (ListView::complete is false; its user walks the cells instead).
  /// keep(i, j) may drop candidates that can never pair (the knit's rest-mesh exclusion).
  template <typename Pred = AnyPair>
  void build_for(const exec::Exec& ex, const Vec3<T>* q, const std::uint32_t* active, std::size_t n,
                 const Vec3<T>* x, const CellView<T>& cells, T radius2, std::uint32_t capacity,
                 Pred keep = {}) {
    capacity_ = (capacity + 3) / 4 * 4;
    count_.resize(n);
    list_.resize(std::size_t(capacity_) * n);
    exec::for_each(ex, n,
                   list_detail::ListBuilder<T, Pred>{q, x, active, cells, radius2, capacity_,
                                                     count_.data(), list_.data(), keep},
                   "neighbours.build_for");
  }
  ListView<T> view() const { return {count_.data(), list_.data(), capacity_}; }
  /// Slots per particle now; most neighbours of one particle at the last build.
  std::uint32_t capacity() const { return capacity_; }
  std::uint32_t most() const { return most_; }
  std::size_t bytes() const { return count_.capacity_bytes() + list_.capacity_bytes(); }

private:
  exec::DeviceBuffer<std::uint32_t> count_, list_;
  std::uint32_t capacity_ = 0, most_ = 0;
};

} // namespace kf
