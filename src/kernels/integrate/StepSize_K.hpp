#pragma once
// The fluid's time-step rule, written once for the host and the device: the host applies it
// where it reads the motion bounds itself; on the GPU a one-thread kernel applies it to the bounds
// the last kick left in device memory, so the next step's drift is queued before the host knows
// dt (the host reads the step back while the drift runs). Double precision on both sides, with
// only correctly rounded operations (+, *, /, sqrt, min), so both give the same dt bit for bit.
#include "core/HostDevice.hpp"
#include "core/Math.hpp"
#include "kernels/integrate/Verlet.hpp"

#include <cstdint>

namespace kf {

/// The limits on the fluid's step: dt <= limit (dt_max, the viscous and coupling limits),
/// dt <= cfl h / (c + v_max), dt <= force_factor sqrt(h / a_max).
struct FluidStepRule {
  double limit = 0;
  double cfl = 0, h = 0, sound = 0;
  double force_factor = 0;
  double dt_min = 0;
};

/// The largest step the rule allows at motion bounds v2 = max |v|^2, a2 = max |a|^2.
KF_HD KF_INLINE double fluid_stable_dt(const FluidStepRule& r, double v2, double a2) {
  const double vmax = ksqrt(v2), amax = ksqrt(a2);
  double dt = r.limit;
  const double cfl_dt = r.cfl * r.h / (r.sound + vmax);
  dt = cfl_dt < dt ? cfl_dt : dt;
  if (amax > 0) {
    const double force_dt = r.force_factor * ksqrt(r.h / amax);
    dt = force_dt < dt ? force_dt : dt;
  }
  return dt;
}

/// The step that lands exactly on an output time `remaining` ahead without leaving a sliver
/// of a step before it: the whole remainder when dt reaches it, half of it when two steps would.
KF_HD KF_INLINE double landed_dt(double dt, double remaining, bool& lands) {
  lands = false;
  if (remaining <= dt * (1 + 1e-9)) {
    lands = true;
    return remaining;
  }
  return remaining < 2 * dt ? 0.5 * remaining : dt;
}

/// A step planned on the device: dt (0 when the bounds were not finite or the stable step fell
/// below dt_min, so that the drift queued with it moves nothing) and what the host checks.
template <typename T>
struct StepPlan {
  double dt = 0;
  double stable_dt = 0; // before landing
  MotionBounds<T> bounds{};
  std::uint32_t lands = 0;
  std::uint32_t finite = 0;
};

/// One thread: *out = *in with NaN read as +infinity, for an all-reduce of maxima over the ranks
/// (which must not lose a blown-up rank's bounds: the plan then finds them not finite).
template <typename T>
struct BoundsForJobMax {
  const MotionBounds<T>* in;
  MotionBounds<T>* out;

  KF_HD void operator()(std::size_t) const {
    const MotionBounds<T> b = *in;
    out->v2 = nan_as_inf(b.v2);
    out->a2 = nan_as_inf(b.a2);
  }
};

/// One thread: the step from the fluid's motion bounds, written to *plan.
template <typename T>
struct PlanFluidStep {
  FluidStepRule rule;
  const MotionBounds<T>* bounds;
  double remaining;
  StepPlan<T>* plan;

  KF_HD void operator()(std::size_t) const {
    StepPlan<T> p;
    p.bounds = *bounds;
    const double v2 = static_cast<double>(p.bounds.v2), a2 = static_cast<double>(p.bounds.a2);
    p.finite = v2 - v2 == 0 && a2 - a2 == 0; // inf - inf and NaN - NaN are NaN
    p.stable_dt = fluid_stable_dt(rule, v2, a2);
    bool lands = false;
    const double dt = landed_dt(p.stable_dt, remaining, lands);
    const bool ok = p.finite && !(p.stable_dt < rule.dt_min);
    p.dt = ok ? dt : 0.0;
    p.lands = ok && lands;
    *plan = p;
  }
};

} // namespace kf
