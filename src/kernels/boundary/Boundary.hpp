#pragma once
#include "kernels/boundary/RigidShape.hpp"
#include "kernels/exec/Algorithms.hpp"
#include "kernels/particles/FluidSet.hpp"

namespace kf {

/// Moves the boundary particles of translating obstacles to x0 + offset of their shape.
/// shapes is the device array of obstacles (walls never move).
template <typename T>
void move_boundary(const exec::Exec& ex, BoundaryView<T> b, const RigidShape<T>* shapes);

/// Last line of defence against penetration: a particle closer than `margin` to a solid (or inside
/// it) is put back at distance `margin` and loses its velocity into the solid (relative to the
/// shape). Returns how many particles were corrected; with working boundary forces this stays 0
/// or rare, and the run reports it.
template <typename T>
std::size_t enforce_rigid_shapes(const exec::Exec& ex, Vec3<T>* x, Vec3<T>* v, std::size_t n,
                                 const RigidShape<T>* shapes, std::size_t n_shapes, T margin,
                                 const char* label);

/// Smallest signed distance of any of the n points to any shape (negative: inside a solid),
/// used by tests and diagnostics.
template <typename T>
T min_rigid_distance(const exec::Exec& ex, const Vec3<T>* x, std::size_t n,
                     const RigidShape<T>* shapes, std::size_t n_shapes);

} // namespace kf
