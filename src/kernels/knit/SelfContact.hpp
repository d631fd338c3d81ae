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

  /// Sorts the points into the grid and gathers the cell-ordered copies (positions, velocities,
  /// rest positions, masses, pieces, ids). Call after the points moved, before add_forces/stats.
  void update(const exec::Exec& ex, KnitSet<T>& set);
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
};

} // namespace kf
