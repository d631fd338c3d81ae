#include "kernels/knit/Knit.hpp"

#include "kernels/knit/KnitEvaluators_K.hpp"

namespace kf {

// H200, the drape (self-contact on), us a substep, one pass against two (springs + self-contact):
// 28k points 15.2 / 21.2, 50k 18.3 / 23.9, 77k 29.0 / 34.2, 112k 42.1 / 45.1, 152k 67.5 / 66.9,
// 198k 175.8 / 159.8 (its self-contact walks cells there: 104 us). Past 150k, two.
const std::size_t kKnitOnePassUpTo = 150000;

template <typename T>
void knit_forces(const exec::Exec& ex, KnitView<T> p, const SpringView<T>& s, Vec3<T> gravity,
                 const VolumeView<T>& vol) {
  // Lanes a point (KnitLanes.hpp): 50k points alone fill a sixth of an H100's threads, too few
  // to hide the latency of the neighbours' loads.
  exec::for_each_lanes<kKnitLanes>(ex, p.n, SpringForceEvaluator<T>{p, s, vol, gravity},
                                   "knit.springs");
}

template <typename T>
void knit_forces(const exec::Exec& ex, std::size_t n, const KnitForceTerms<T>& own,
                 std::size_t one_pass_up_to) {
  if (own.with_self && !own.held && n > one_pass_up_to) {
    // The separate passes' own evaluators, as knit_forces above and KnitSelfContact launch them.
    exec::for_each_lanes<kKnitLanes>(ex, n, own.springs, "knit.springs");
    exec::for_each_lanes<kKnitLanes>(ex, n, own.self, "knit.self_contact");
    return;
  }
  knit_forces_with(ex, n, own, NoKnitTerm{}, "knit.forces");
}

template <typename T>
void knit_handle_work(const exec::Exec& ex, KnitView<T> p, const Vec3<T>* held, Vec3<T> gravity,
                      const Vec3<T>* handle_v, T h, double* work) {
  exec::transform_reduce_into(ex, p.n, exec::SumOp{},
                              HandleWorkEvaluator<T>{p, held, gravity, handle_v, h}, work,
                              "knit.handle_work");
}

template <typename T>
double knit_spring_energy(const exec::Exec& ex, KnitView<T> p, const SpringView<T>& s,
                          const VolumeView<T>& vol) {
  return exec::transform_reduce(ex, p.n, 0.0, exec::SumOp{}, SpringEnergyEvaluator<T>{p, s, vol},
                                "knit.energy");
}

template <typename T>
double knit_kinetic_energy(const exec::Exec& ex, KnitView<T> p) {
  return exec::transform_reduce(
      ex, p.n, 0.0, exec::SumOp{},
      [=] KF_HD(std::size_t i) { return 0.5 * double(p.m[i]) * double(norm2(p.v[i])); },
      "knit.kinetic");
}

template <typename T>
double knit_potential_energy(const exec::Exec& ex, KnitView<T> p, Vec3<T> g) {
  return exec::transform_reduce(
      ex, p.n, 0.0, exec::SumOp{},
      [=] KF_HD(std::size_t i) { return -double(p.m[i]) * double(dot(g, p.x[i])); },
      "knit.potential");
}

struct LimitsMinOp {
  template <typename T>
  KF_HD KF_INLINE SpringLimits<T> operator()(const SpringLimits<T>& a,
                                             const SpringLimits<T>& b) const {
    return {a.spring < b.spring ? a.spring : b.spring,
            a.damping < b.damping ? a.damping : b.damping};
  }
};

template <typename T>
void knit_spring_limits(const exec::Exec& ex, KnitView<T> p, const SpringView<T>& s,
                        const VolumeView<T>& vol, T& spring, T& damping) {
  const SpringLimits<T> l = exec::transform_reduce(
      ex, p.n, SpringLimits<T>{}, LimitsMinOp{}, SpringLimitEvaluator<T>{p, s, vol}, "knit.limits");
  spring = l.spring;
  damping = l.damping;
}

template <typename T>
PartnerReach<T> knit_partner_reach(const exec::Exec& ex, std::size_t owned, const Vec3<T>* x,
                                   const SpringView<T>& s, const VolumeView<T>& vol) {
  return exec::transform_reduce(ex, owned, PartnerReach<T>{}, PartnerReachMaxOp{},
                                PartnerReachEvaluator<T>{x, s, vol}, "knit.partner_reach");
}

#define KF_INSTANTIATE(T)                                                                          \
  template void knit_forces<T>(const exec::Exec&, KnitView<T>, const SpringView<T>&, Vec3<T>,      \
                               const VolumeView<T>&);                                              \
  template void knit_forces<T>(const exec::Exec&, std::size_t, const KnitForceTerms<T>&,           \
                               std::size_t);                                                       \
  template void knit_handle_work<T>(const exec::Exec&, KnitView<T>, const Vec3<T>*, Vec3<T>,       \
                                    const Vec3<T>*, T, double*);                                   \
  template double knit_spring_energy<T>(const exec::Exec&, KnitView<T>, const SpringView<T>&,      \
                                        const VolumeView<T>&);                                     \
  template double knit_kinetic_energy<T>(const exec::Exec&, KnitView<T>);                          \
  template double knit_potential_energy<T>(const exec::Exec&, KnitView<T>, Vec3<T>);               \
  template void knit_spring_limits<T>(const exec::Exec&, KnitView<T>, const SpringView<T>&,        \
                                      const VolumeView<T>&, T&, T&);                               \
  template PartnerReach<T> knit_partner_reach<T>(const exec::Exec&, std::size_t, const Vec3<T>*,   \
                                                 const SpringView<T>&, const VolumeView<T>&);
KF_INSTANTIATE(float)
KF_INSTANTIATE(double)
#undef KF_INSTANTIATE

} // namespace kf
