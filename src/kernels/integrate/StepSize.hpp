#pragma once
// The fluid's step planned on the device (StepSize_K.hpp): the host queues it, and the drift
// that reads it, before it knows dt.
#include "kernels/exec/Algorithms.hpp"
#include "kernels/integrate/StepSize_K.hpp"

namespace kf {

/// *plan = the step the rule allows at *bounds (memory on ex.backend), landing `remaining` ahead.
/// Nothing waits: the host reads *plan back later (exec::PendingRead).
template <typename T>
void plan_fluid_step(const exec::Exec& ex, const FluidStepRule& rule, const MotionBounds<T>* bounds,
                     double remaining, StepPlan<T>* plan);

/// *out = *in with NaN read as +infinity (BoundsForJobMax), on ex.backend; nothing waits.
template <typename T>
void bounds_for_job_max(const exec::Exec& ex, const MotionBounds<T>* in, MotionBounds<T>* out);

} // namespace kf
