#pragma once
// Velocity Verlet (kick-drift-kick), the paper's integrator (§7), and the step-size reductions.
#include "core/Vec3.hpp"
#include "kernels/exec/Algorithms.hpp"

#include <cstdint>

namespace kf {

/// Points whose motion is prescribed (knit pins and handles): point i with handle[i] != kNoHandle
/// moves with velocity[handle[i]] and ignores its acceleration. Empty (the default): none.
inline constexpr std::uint32_t kNoHandle = 0xFFFFFFFFu;
template <typename T>
struct Prescribed {
  const std::uint32_t* handle = nullptr;
  const Vec3<T>* velocity = nullptr;
};

/// The half-kicked velocity of point i: prescribed, or keep (v + a dt/2).
template <typename T>
KF_HD KF_INLINE Vec3<T> half_kick(std::size_t i, const Vec3<T>* v, const Vec3<T>* a, T half, T keep,
                                  const Prescribed<T>& fixed) {
  if (fixed.handle && fixed.handle[i] != kNoHandle)
    return fixed.velocity[fixed.handle[i]];
  return (v[i] + a[i] * half) * keep;
}

/// The step a drift takes: T(*dt_device) when the step was planned on the device
/// (StepSize_K.hpp), else dt.
template <typename T>
KF_HD KF_INLINE T drift_step(T dt, const double* dt_device) {
  return dt_device ? static_cast<T>(*dt_device) : dt;
}

/// v = keep (v + a dt/2), then x += v dt. keep = exp(-zeta dt/2) < 1 damps (settling); 1 does not.
/// With dt_device, dt is T(*dt_device), read on the device (a step planned there, StepSize_K.hpp).
template <typename T>
void kick_drift(const exec::Exec& ex, Vec3<T>* x, Vec3<T>* v, const Vec3<T>* a, std::size_t n, T dt,
                T keep, const char* label, Prescribed<T> fixed = {},
                const double* dt_device = nullptr);
/// v = keep (v + a dt/2).
template <typename T>
void kick(const exec::Exec& ex, Vec3<T>* v, const Vec3<T>* a, std::size_t n, T dt, T keep,
          const char* label, Prescribed<T> fixed = {});

/// max |v|^2 and max |a|^2 over n particles, in one pass. NaN anywhere yields NaN.
template <typename T>
struct MotionBounds {
  T v2 = T(0), a2 = T(0);
};
template <typename T>
MotionBounds<T> motion_bounds(const exec::Exec& ex, const Vec3<T>* v, const Vec3<T>* a,
                              std::size_t n, const char* label);
/// The same written to *out on the device (nothing waits), so that several sets' bounds come
/// back in one read.
template <typename T>
void motion_bounds_to(const exec::Exec& ex, const Vec3<T>* v, const Vec3<T>* a, std::size_t n,
                      MotionBounds<T>* out, const char* label);
/// kick, and the motion bounds of the kicked velocities written to *out, in one pass: the step's
/// last stage and the next step's time-step reduction read the same arrays (fused: one read).
/// `only` (null: all): the rows with only[i] != 0 are kicked and bounded, the others left as
/// they are (a split's ghosts whose accelerations are still in flight: kick_rows later).
template <typename T>
void kick_bounds(const exec::Exec& ex, Vec3<T>* v, const Vec3<T>* a, std::size_t n, T dt, T keep,
                 MotionBounds<T>* out, const char* label, const std::uint32_t* only = nullptr);
/// The same kick (v = keep (v + a dt/2), as kick_bounds does it) of the rows `rows` names.
template <typename T>
void kick_rows(const exec::Exec& ex, Vec3<T>* v, const Vec3<T>* a, const exec::Rows& rows, T dt,
               T keep, const char* label);

} // namespace kf
