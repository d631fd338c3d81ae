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
  KF_HD KF_INLINE void for_each_neighbour(std::size_t i, const Vec3<T>&, F&& f) const {
    const std::uint32_t c = count[i];
    const std::uint32_t* row = list + i * capacity;
    for (std::uint32_t k = 0; k < c; ++k)
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
  void build_for(const exec::Exec& ex, const Vec3<T>* q, const std::uint32_t* active, std::size_t n,
                 const Vec3<T>* x, const CellView<T>& cells, T radius2, std::uint32_t capacity);
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
