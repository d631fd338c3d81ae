#pragma once
// Knit stages (paper §3): damped springs and gravity, the integrator with prescribed points, and
// the quantities the step-size control and the tests need.
#include "kernels/boundary/RigidShape.hpp"
#include "kernels/knit/SpringTopology.hpp"
#include "kernels/particles/KnitSet.hpp"

namespace kf {

/// a = spring forces / m + g for free points, 0 for points on a handle.
template <typename T>
void knit_forces(const exec::Exec& ex, KnitView<T> p, const SpringView<T>& s, Vec3<T> gravity);

/// Velocity Verlet half kick + drift; points on handle h move with handle_v[h] instead.
/// keep = exp(-zeta dt/2) damps (settling), 1 does not.
template <typename T>
void knit_kick_drift(const exec::Exec& ex, KnitView<T> p, const Vec3<T>* handle_v, T dt, T keep);
/// Velocity Verlet second half kick (handles keep their velocity).
template <typename T>
void knit_kick(const exec::Exec& ex, KnitView<T> p, const Vec3<T>* handle_v, T dt, T keep);

/// Elastic energy of all springs [J] (double accumulation).
template <typename T>
double knit_spring_energy(const exec::Exec& ex, KnitView<T> p, const SpringView<T>& s);
/// Kinetic energy sum 1/2 m v^2 and gravitational potential -sum m g.x [J].
template <typename T>
double knit_kinetic_energy(const exec::Exec& ex, KnitView<T> p);
template <typename T>
double knit_potential_energy(const exec::Exec& ex, KnitView<T> p, Vec3<T> gravity);

/// Smallest sqrt(m / sum k) and m / sum c over the free points (the explicit step limits).
template <typename T>
void knit_spring_limits(const exec::Exec& ex, KnitView<T> p, const SpringView<T>& s, T& spring,
                        T& damping);

/// Keeps every point at least `radius` outside every shape: a point closer is put back on that
/// surface, loses its velocity into the shape and, by Coulomb friction, up to `friction` times
/// that lost normal speed of its tangential speed (relative to the shape). Returns the count.
template <typename T>
std::size_t knit_collide_rigid(const exec::Exec& ex, KnitView<T> p, const RigidShape<T>* shapes,
                               std::size_t n_shapes, T radius, T friction);

} // namespace kf
