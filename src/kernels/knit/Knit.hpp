#pragma once
// Knit stages (paper §3): damped springs and gravity, and the quantities the step-size control
// and the tests need. Integration (kick_drift/kick with Prescribed points) and contact with
// solids (enforce_rigid_shapes) are the shared kernels.
#include "kernels/knit/KnitForces_K.hpp"
#include "kernels/knit/SpringTopology.hpp"
#include "kernels/knit/VolumeTopology.hpp"
#include "kernels/particles/KnitSet.hpp"

namespace kf {

/// a = (spring + volume forces) / m + g for free points, 0 for points on a handle.
template <typename T>
void knit_forces(const exec::Exec& ex, KnitView<T> p, const SpringView<T>& s, Vec3<T> gravity,
                 const VolumeView<T>& vol = {});

/// Up to how many points the springs and the self-contact take one pass (KnitPointForces: one
/// launch, a written once); past it two (the springs', then the self-contact's adding to a: the
/// same sums in the same order), whose kernels keep more threads resident (Knit.cpp: measured).
extern const std::size_t kKnitOnePassUpTo;

/// a = (springs + volume cells + self-contact, when own.with_self) / m + g on points [0, n)
/// (KnitPointForces: one pass up to one_pass_up_to points, or where the handles' held forces are
/// written); 0 on a handle's points.
template <typename T>
void knit_forces(const exec::Exec& ex, std::size_t n, const KnitForceTerms<T>& own,
                 std::size_t one_pass_up_to = kKnitOnePassUpTo);

/// Adds to *work (memory on ex.backend; nothing waits) the work the moving handles' constraint
/// does over a time h at the current forces (HandleWorkEvaluator): held, the other forces on
/// each handle's point (the force pass's KnitForceTerms::held); handle_v, each handle's
/// velocity. The watchdog's energy budget (domain/Watchdog).
template <typename T>
void knit_handle_work(const exec::Exec& ex, KnitView<T> p, const Vec3<T>* held, Vec3<T> gravity,
                      const Vec3<T>* handle_v, T h, double* work);

/// Elastic energy of all springs and volume cells [J] (double accumulation).
template <typename T>
double knit_spring_energy(const exec::Exec& ex, KnitView<T> p, const SpringView<T>& s,
                          const VolumeView<T>& vol = {});
/// Kinetic energy sum 1/2 m v^2 and gravitational potential -sum m g.x [J].
template <typename T>
double knit_kinetic_energy(const exec::Exec& ex, KnitView<T> p);
template <typename T>
double knit_potential_energy(const exec::Exec& ex, KnitView<T> p, Vec3<T> gravity);

/// The farthest partner of the first `owned` points (squared) and whether one is absent, from
/// their localized rows (KnitHalo's check on N ranks).
template <typename T>
PartnerReach<T> knit_partner_reach(const exec::Exec& ex, std::size_t owned, const Vec3<T>* x,
                                   const SpringView<T>& s, const VolumeView<T>& vol);

/// Smallest sqrt(m / sum k) and m / sum c over the free points (the explicit step limits).
template <typename T>
void knit_spring_limits(const exec::Exec& ex, KnitView<T> p, const SpringView<T>& s,
                        const VolumeView<T>& vol, T& spring, T& damping);

} // namespace kf
