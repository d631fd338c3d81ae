#pragma once
#include "kernels/boundary/RigidContact_K.hpp"
#include "kernels/exec/Algorithms.hpp"
#include "kernels/integrate/Verlet.hpp"
#include "kernels/particles/FluidSet.hpp"

namespace kf {

/// Moves the boundary particles of translating obstacles to x0 + offset of their shape.
/// shapes is the device array of obstacles (walls never move).
template <typename T>
void move_boundary(const exec::Exec& ex, BoundaryView<T> b, const RigidShape<T>* shapes);

/// Keeps points at least `margin` outside every solid: a point closer (or inside) is put back at
/// distance `margin`, loses its velocity into the solid (relative to the solid) and, by Coulomb
/// friction, up to `friction` times that lost normal speed of its tangential speed. For the fluid
/// this is the last line of defence (friction 0; with working boundary forces it stays rare);
/// for the knit it is the contact with solids. Points with fixed[i] != kNoHandle (prescribed
/// motion) are left alone; fixed may be null. The number of points corrected is added to
/// *count, a counter in ex.backend's memory, so nothing waits for the device.
template <typename T>
void enforce_rigid_shapes(const exec::Exec& ex, Vec3<T>* x, Vec3<T>* v, std::size_t n,
                          const RigidShape<T>* shapes, std::size_t n_shapes, T margin, T friction,
                          const std::uint32_t* fixed, std::uint64_t* count, const char* label,
                          ContactWork<T> work = {});

/// One kernel for what a substep of velocity Verlet does between two force evaluations: with
/// close_previous, the previous substep's closing half kick (the same a); then kick_drift; then
/// enforce_rigid_shapes (margin, friction, counting into *count; `work`: the moving solids' work,
/// RigidContact_K.hpp). The same arithmetic as the
/// three calls in a row (bit for bit): a prescribed point's velocity is set by the second kick
/// whatever the first left, so `fixed` may already hold this substep's velocities. With
/// dt_device, dt is T(*dt_device), read on the device (a step planned there, StepSize_K.hpp).
/// counted (null: all): the points whose corrections are counted (1), the others moved alike
/// (a rank's ghosts, kept over steps, which their owners count).
template <typename T>
void kick_drift_contact(const exec::Exec& ex, Vec3<T>* x, Vec3<T>* v, const Vec3<T>* a,
                        std::size_t n, T dt, T keep, bool close_previous, Prescribed<T> fixed,
                        const RigidShape<T>* shapes, std::size_t n_shapes, T margin, T friction,
                        std::uint64_t* count, const char* label, const double* dt_device = nullptr,
                        const std::uint32_t* counted = nullptr, ContactWork<T> work = {});

/// Smallest signed distance of any of the n points to any shape (negative: inside a solid),
/// used by tests and diagnostics.
template <typename T>
T min_rigid_distance(const exec::Exec& ex, const Vec3<T>* x, std::size_t n,
                     const RigidShape<T>* shapes, std::size_t n_shapes);

} // namespace kf
