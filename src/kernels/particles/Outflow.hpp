#pragma once
// Fluid leaving the domain through a side without a wall is gone: removed from the set, and
// counted, so free + absorbed + gone fluid mass still adds up to what the scene started with.
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

} // namespace kf
