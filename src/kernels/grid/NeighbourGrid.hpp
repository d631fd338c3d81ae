#pragma once
#include "kernels/exec/Algorithms.hpp"
#include "kernels/grid/GridGeometry.hpp"

namespace kf {

/// Whether a grid sorted when the points were at x0 is stale for x: some point moved farther
/// than the skin (the cell's margin over the interaction reach), or the count changed. A NaN
/// counts as moved (the step-size check reports it).
template <typename T>
bool moved_past_skin(const exec::Exec& ex, const exec::DeviceBuffer<Vec3<T>>& x,
                     const exec::DeviceBuffer<Vec3<T>>& x0, T skin2, const char* label) {
  const std::size_t n = x.size();
  if (x0.size() != n)
    return true;
  const Vec3<T>* a = x.data();
  const Vec3<T>* b = x0.data();
  const T moved2 = exec::transform_reduce(
      ex, n, T(0), exec::MaxOp{}, [=] KF_HD(std::size_t i) { return norm2(a[i] - b[i]); }, label);
  return !(moved2 <= skin2);
}

/// Sorts one particle set by cell (Morton order) and keeps the cell tables for neighbour loops.
/// After build(), permutation()[i] is the old index of the particle now at i; the owner reorders
/// its fields with it so that positions and tables agree.
template <typename T>
class NeighbourGrid {
public:
  NeighbourGrid(exec::Backend b, const GridGeometry<T>& geo);

  /// Grid covering [lo, hi] with cells of edge `cell` plus one cell of padding on every side.
  static GridGeometry<T> cover(const Vec3d& lo, const Vec3d& hi, double cell);

  void build(const exec::Exec& ex, const Vec3<T>* x, std::size_t n);
  const exec::DeviceBuffer<std::uint32_t>& permutation() const { return perm_; }
  CellView<T> view() const { return {geo_, rank_.data(), start_.data(), end_.data()}; }
  const GridGeometry<T>& geometry() const { return geo_; }
  std::size_t bytes() const;

private:
  GridGeometry<T> geo_;
  int key_bits_ = 1;
  bool cleared_ = false; // start/end zeroed once; later builds clear only the cells last used
  exec::DeviceBuffer<std::uint32_t> rank_, start_, end_, keys_, perm_;
};

} // namespace kf
