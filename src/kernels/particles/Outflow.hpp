#pragma once
// Fluid leaving the domain through a side without a wall is gone: removed from the set, and
// counted, so free + absorbed + gone fluid mass still adds up to what the scene started with.
#include "kernels/grid/NeighbourGrid.hpp"
#include "kernels/particles/FluidSet.hpp"

namespace kf {

struct OutflowResult {
  std::size_t particles = 0;
  double mass = 0;
};

/// Removes the fluid particles outside [lo, hi] (any component), keeping the others' order.
template <typename T>
OutflowResult remove_outside(const exec::Exec& ex, FluidSet<T>& fluid,
                             exec::DeviceBuffer<std::uint32_t>& flags, const Vec3<T>& lo,
                             const Vec3<T>& hi);

/// The same removal folded into the fluid's sort: sorts the fluid by `grid`'s cells with the
/// particles outside [lo, hi] sorted last (NeighbourGrid::build_keeping), reorders it, and
/// drops those; returns how many they were and adds their mass to *mass (memory on ex.backend,
/// nothing waits for it). One sort and one reorder for what was a compaction, then both; the
/// host waits only for the count, while the reorder runs. `acceleration`: as FluidSet::reorder.
template <typename T>
std::size_t sort_removing_outside(const exec::Exec& ex, NeighbourGrid<T>& grid, FluidSet<T>& fluid,
                                  const Vec3<T>& lo, const Vec3<T>& hi, double* mass,
                                  bool acceleration = true);

} // namespace kf
