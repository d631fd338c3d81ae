#pragma once
// Knit self-collision stage: a neighbour grid over the knit points (sorting a permutation, not
// the points), cell-ordered copies of what the pair loop reads, and the DEM force pass.
#include "kernels/grid/NeighbourGrid.hpp"
#include "kernels/knit/SelfContact_K.hpp"
#include "kernels/particles/KnitSet.hpp"

namespace kf {

template <typename T>
class KnitSelfContact {
public:
  /// geo: a grid with cells no smaller than 2 * params.radius.
  KnitSelfContact(exec::Backend b, const GridGeometry<T>& geo, const SelfContactParams<T>& params);

  /// Brings the cell-ordered copies up to date. The grid is sorted again only when a point moved
  /// farther than the skin (cell - 2R) since the last sort: until then every pair within 2R is
  /// still found in the 27 cells around a point, and only positions and velocities are gathered
  /// again through the kept permutation. Call after the points moved, before add_forces/stats.
  void update(const exec::Exec& ex, KnitSet<T>& set);
  /// Grid sorts so far (for the benchmark and the tests).
  std::uint64_t sorts() const { return sorts_; }
  /// a += self-contact force / m on every free point (a already holds springs and gravity).
  void add_forces(const exec::Exec& ex, KnitSet<T>& set) const;
  /// Contacts, penalty energy and closest approach at the last update.
  SelfContactStats stats(const exec::Exec& ex, KnitSet<T>& set) const;

  const SelfContactParams<T>& params() const { return params_; }
  std::size_t bytes() const;

private:
  SortedKnitView<T> sorted() const;
  SelfContactParams<T> params_;
  NeighbourGrid<T> grid_;
  exec::DeviceBuffer<Vec3<T>> x_, v_, rest_;
  exec::DeviceBuffer<T> m_;
  exec::DeviceBuffer<std::uint16_t> piece_;
  exec::DeviceBuffer<std::uint64_t> id_;
  exec::DeviceBuffer<Vec3<T>> x_sorted_at_; // positions at the last sort, in knit order
  T skin2_;
  std::uint64_t sorts_ = 0;
};

} // namespace kf
