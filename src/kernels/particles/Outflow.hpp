#pragma once
// Fluid leaving the domain through a side without a wall is gone: removed from the set, and
// counted, so free + absorbed + gone fluid mass still adds up to what the scene started with.
#include "kernels/grid/NeighbourGrid.hpp"
#include "kernels/particles/FluidSet.hpp"

namespace kf {

/// Removes the fluid particles outside [lo, hi] (any component; a NaN counts as inside) in the
/// fluid's sort: sorts the fluid by `grid`'s cells with those particles sorted last
/// (NeighbourGrid::build_keeping), reorders it, and drops them; returns how many they were and
/// adds their mass to *mass (memory on ex.backend, nothing waits for it). One sort and one
/// reorder for what was a compaction, then both; the host waits only for the count, while the
/// reorder runs. `carry`: as FluidSet::reorder.
template <typename T>
std::size_t sort_removing_outside(const exec::Exec& ex, NeighbourGrid<T>& grid, FluidSet<T>& fluid,
                                  const Vec3<T>& lo, const Vec3<T>& hi, double* mass,
                                  typename FluidSet<T>::Carry carry = {});

} // namespace kf
