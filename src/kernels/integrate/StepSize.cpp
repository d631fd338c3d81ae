#include "kernels/integrate/StepSize.hpp"

namespace kf {

template <typename T>
void plan_fluid_step(const exec::Exec& ex, const FluidStepRule& rule, const MotionBounds<T>* bounds,
                     double remaining, StepPlan<T>* plan) {
  exec::for_each(ex, 1, PlanFluidStep<T>{rule, bounds, remaining, plan}, "integrate.dt");
}

template void plan_fluid_step<float>(const exec::Exec&, const FluidStepRule&,
                                     const MotionBounds<float>*, double, StepPlan<float>*);
template void plan_fluid_step<double>(const exec::Exec&, const FluidStepRule&,
                                      const MotionBounds<double>*, double, StepPlan<double>*);

} // namespace kf
