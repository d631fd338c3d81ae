// SimulationT<T>'s step: the stable step size (one global reduction on N ranks), the step
// planned on the device, and the report of an unstable one.
#include "domain/SimulationT.hpp"

#include <chrono>
#include <sstream>

namespace kf {

template <typename T>
double SimulationT<T>::stable_dt() {
  const auto& s = scene_.solver;
  double dt = s.dt_max;
  if (!fluid_on_) {
    if (!knit_on_)
      return dt;
    if (!ranks_)
      return std::min(dt, knit_stable_dt(nullptr));
    knit_->motion_bounds_to(bounds_.data());
    auto kb = bounds_.host_value(0);
    job_bounds(&kb, 1);
    return std::min(dt, knit_stable_dt(&kb));
  }
  if (knit_on_) { // both sets' bounds in one read
    queue_both_bounds();
    return both_bounds_dt();
  }
  auto f = fluid_->view();
  MotionBounds<T> mb;
  if (fluid_bounds_ready_)
    mb = bounds_.host_value(1);
  else
    mb = motion_bounds(ex_, f.v, f.a, f.n, "integrate.dt");
  if (ranks_)           // one dt for the job: the largest speed and acceleration of all ranks
    job_bounds(&mb, 1); // (NaN read as infinite: every rank reports the instability below)
  return std::min(dt, fluid_dt(mb));
}

template <typename T>
double SimulationT<T>::fluid_dt(const MotionBounds<T>& mb) {
  fluid_bounds_ = mb;
  if (!(std::isfinite(double(mb.v2)) && std::isfinite(double(mb.a2))))
    report_instability("a fluid velocity or acceleration is not finite");
  return fluid_stable_dt(fluid_step_rule(), double(mb.v2), double(mb.a2));
}

template <typename T>
void SimulationT<T>::queue_both_bounds() {
  auto f = fluid_->view();
  knit_->motion_bounds_to(bounds_.data());
  motion_bounds_to(ex_, f.v, f.a, f.n, bounds_.data() + 1, "integrate.dt");
  if (!bounds_read_)
    bounds_read_.emplace(ex_.backend, 2, "integrate.dt");
  else if (bounds_read_->pending()) // a step that threw before settling it (the watchdog's)
    bounds_read_->wait();
  bounds_read_->start(bounds_.data());
}

template <typename T>
double SimulationT<T>::both_bounds_dt() {
  const auto r = bounds_read_->wait();
  MotionBounds<T> both[2] = {r[0], r[1]};
  if (ranks_)
    job_bounds(both, 2);
  const double dt = std::min(scene_.solver.dt_max, knit_stable_dt(&both[0]));
  return std::min(dt, fluid_dt(both[1]));
}

template <typename T>
bool SimulationT<T>::reads_bounds_behind() const {
  // The knit's and the fluid's bounds (one read) taken while the stages that need no step size
  // run: the pipeline must open with one (the coupling's saturation).
  const auto& st = pipeline_.stages();
  return knit_on_ && fluid_on_ && !st.empty() && st.front().before_dt;
}

template <typename T>
void SimulationT<T>::take_dt(double dt, double remaining) {
  if (dt < scene_.solver.dt_min)
    report_instability("the stable time step " + std::to_string(dt) + " s fell below dt_min " +
                       std::to_string(scene_.solver.dt_min) + " s");
  bool lands = false;
  dt_ = landed_dt(dt, remaining, lands);
  step_lands_ = lands;
}

template <typename T>
void SimulationT<T>::settle_dt() {
  if (!dt_pending_)
    return;
  dt_pending_ = false;
  take_dt(both_bounds_dt(), dt_remaining_);
}

template <typename T>
void SimulationT<T>::job_bounds(MotionBounds<T>* mb, int n) {
  std::vector<double> b(2 * n);
  for (int k = 0; k < n; ++k) {
    b[2 * k] = double(mb[k].v2);
    b[2 * k + 1] = double(mb[k].a2);
  }
  for (double& v : b)
    v = nan_as_inf(v);
  // Its time is mostly the wait for the slowest rank's step: the split's, reported with it.
  const auto t0 = std::chrono::steady_clock::now();
  MPI_Allreduce(MPI_IN_PLACE, b.data(), 2 * n, MPI_DOUBLE, MPI_MAX, ranks_->mpi().comm());
  ranks_->add_reduction(
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  for (int k = 0; k < n; ++k) {
    mb[k].v2 = static_cast<T>(b[2 * k]);
    mb[k].a2 = static_cast<T>(b[2 * k + 1]);
  }
}

template <typename T>
FluidStepRule SimulationT<T>::fluid_step_rule() const {
  const auto& s = scene_.solver;
  FluidStepRule r;
  r.limit = std::min(s.dt_max, coupling_fluid_limit_);
  if (scene_.fluid.viscosity > 0)
    r.limit = std::min(r.limit, s.viscous_factor * h_ * h_ * scene_.fluid.rest_density /
                                    scene_.fluid.viscosity);
  r.cfl = s.cfl;
  r.h = h_;
  r.sound = scene_.fluid.speed_of_sound;
  r.force_factor = s.force_factor;
  r.dt_min = s.dt_min;
  return r;
}

template <typename T>
bool SimulationT<T>::plans_step_on_device() const {
  // The drift must be the step's first stage (no knit or coupling stages before it, which take
  // dt on the host), its bounds on the device already, and no damping (keep depends on dt). On
  // N ranks the transport must reduce the bounds where they are (NCCL: device memory).
  const auto& s = scene_.solver;
  const bool reducible = !ranks_ || (ex_.backend != exec::Backend::Cpu &&
                                     ranks_->transport_space() == comm::MemorySpace::Device);
  return fluid_on_ && !knit_on_ && !coupling_on_ && fluid_bounds_ready_ && reducible &&
         !(s.damping > 0 && time_ < s.damping_until);
}

template <typename T>
void SimulationT<T>::settle_step() {
  if (!step_pending_)
    return;
  const StepPlan<T> p = plan_read_->wait()[0];
  step_pending_ = false;
  fluid_bounds_ = p.bounds;
  // The plan's dt is 0 in both cases below: the drift queued with it moved nothing.
  if (!p.finite)
    report_instability("a fluid velocity or acceleration is not finite");
  if (p.stable_dt < scene_.solver.dt_min)
    report_instability("the stable time step " + std::to_string(p.stable_dt) +
                       " s fell below dt_min " + std::to_string(scene_.solver.dt_min) + " s");
  dt_ = p.dt;
  step_lands_ = p.lands != 0;
}

template <typename T>
double SimulationT<T>::step(double t_limit) {
  // Land exactly on t_limit (output times), without leaving a sliver of a step before it.
  const double remaining = t_limit - time_;
  dt_pending_ = false; // one left by a step that threw (the watchdog's retry) is not this one's
  if (plans_step_on_device()) {
    if (!plan_read_)
      plan_read_.emplace(ex_.backend, 1, "integrate.dt");
    const MotionBounds<T>* bounds = bounds_.data() + 1;
    if (ranks_) { // one dt for the job: the largest speed and acceleration of all ranks
      static_assert(sizeof(MotionBounds<T>) == 2 * sizeof(T), "v2, a2 reduced as two values");
      MotionBounds<T>* job = bounds_.data() + 2;
      bounds_for_job_max(ex_, bounds, job); // NaN read as infinite: every rank reports it
      ranks_->transport().max_in_place(&job->v2, 2);
      bounds = job;
    }
    plan_fluid_step(ex_, fluid_step_rule(), bounds, remaining, plan_.data());
    plan_read_->start(plan_.data());
    step_pending_ = true;
    dt_ = std::numeric_limits<double>::quiet_NaN(); // known once the drift is queued
  } else if (reads_bounds_behind()) {
    queue_both_bounds(); // read while the first stages run: settle_dt()
    dt_pending_ = true;
    dt_remaining_ = remaining;
    dt_ = std::numeric_limits<double>::quiet_NaN(); // known once settled
  } else {
    take_dt(stable_dt(), remaining);
  }
  fluid_bounds_ready_ = false; // the stages change v and a; the step's last kick writes them
  pipeline_.run(profiling_ ? std::function<void()>([this] { exec::synchronize(ex_.backend); })
                           : std::function<void()>(),
                dt_pending_ ? std::function<void()>([this] { settle_dt(); })
                            : std::function<void()>());
  settle_dt();   // a stage settles it; a pipeline of stages before it only would still
  settle_step(); // the drift stage settles it; a pipeline without one would still
  if (ranks_ && ranks_->forces_pending()) // the kick finishes it: no ghost may stay behind
    throw Error("internal: the forces' refresh still in flight at the end of a step");
  time_ = step_lands_ ? t_limit : time_ + dt_;
  ++steps_;
  return dt_;
}

template <typename T>
void SimulationT<T>::report_instability(const std::string& why, WatchMeasure worst) {
  std::ostringstream msg;
  msg << "instability at step " << steps_ << ", t = " << time_ << " s: " << why;
  // Every rank reports an instability found from the job's bounds: the worst particle is the
  // job's (collective); on one rank, this rank's.
  std::string w;
  try {
    double value = 0;
    w = ranks_ ? describe_worst(worst) : local_worst(worst, &value);
  } catch (const Error& e) { // the report matters more than its details
    w = std::string("not found (") + e.what() + ")";
  }
  if (!w.empty())
    msg << "; worst " << w;
  throw InstabilityError(msg.str());
}

template <typename T>
double SimulationT<T>::knit_stable_dt(const MotionBounds<T>* bounds) {
  try {
    return bounds ? knit_->stable_dt(*bounds) : knit_->stable_dt();
  } catch (const InstabilityError& e) { // the knit names no point: find it
    report_instability(e.what(), WatchMeasure::KnitSpeed);
  }
}

#define KF_INSTANTIATE(T)                                                                          \
  template double SimulationT<T>::stable_dt();                                                     \
  template double SimulationT<T>::fluid_dt(const MotionBounds<T>&);                                \
  template void SimulationT<T>::queue_both_bounds();                                               \
  template double SimulationT<T>::both_bounds_dt();                                                \
  template bool SimulationT<T>::reads_bounds_behind() const;                                       \
  template void SimulationT<T>::take_dt(double, double);                                           \
  template void SimulationT<T>::settle_dt();                                                       \
  template void SimulationT<T>::job_bounds(MotionBounds<T>*, int);                                 \
  template FluidStepRule SimulationT<T>::fluid_step_rule() const;                                  \
  template bool SimulationT<T>::plans_step_on_device() const;                                      \
  template void SimulationT<T>::settle_step();                                                     \
  template double SimulationT<T>::step(double);                                                    \
  template void SimulationT<T>::report_instability(const std::string&, WatchMeasure);              \
  template double SimulationT<T>::knit_stable_dt(const MotionBounds<T>*);
KF_INSTANTIATE(float)
KF_INSTANTIATE(double)
#undef KF_INSTANTIATE

} // namespace kf
