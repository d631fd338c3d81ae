#include "kernels/integrate/StepSize.hpp"

namespace kf {

template <typename T>
void plan_fluid_step(const exec::Exec& ex, const FluidStepRule& rule, const MotionBounds<T>* bounds,
                     double remaining, StepPlan<T>* plan) {
  exec::for_each(ex, 1, PlanFluidStep<T>{rule, bounds, remaining, plan}, "integrate.dt");
}

template <typename T>
void bounds_for_job_max(const exec::Exec& ex, const MotionBounds<T>* in, MotionBounds<T>* out) {
  exec::for_each(ex, 1, BoundsForJobMax<T>{in, out}, "integrate.dt");
}

template void bounds_for_job_max<float>(const exec::Exec&, const MotionBounds<float>*,
                                        MotionBounds<float>*);
template void bounds_for_job_max<double>(const exec::Exec&, const MotionBounds<double>*,
                                         MotionBounds<double>*);
template void plan_fluid_step<float>(const exec::Exec&, const FluidStepRule&,
                                     const MotionBounds<float>*, double, StepPlan<float>*);
template void plan_fluid_step<double>(const exec::Exec&, const FluidStepRule&,
                                      const MotionBounds<double>*, double, StepPlan<double>*);

} // namespace kf
