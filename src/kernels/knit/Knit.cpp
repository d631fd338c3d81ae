#include "kernels/knit/Knit.hpp"

#include "kernels/knit/KnitEvaluators_K.hpp"

namespace kf {

template <typename T>
void knit_forces(const exec::Exec& ex, KnitView<T> p, const SpringView<T>& s, Vec3<T> gravity) {
  exec::for_each(ex, p.n, SpringForceEvaluator<T>{p, s, gravity}, "knit.springs");
}

template <typename T>
void knit_kick_drift(const exec::Exec& ex, KnitView<T> p, const Vec3<T>* handle_v, T dt, T keep) {
  const T half = T(0.5) * dt;
  exec::for_each(
      ex, p.n,
      [=] KF_HD(std::size_t i) {
        const std::uint32_t h = p.handle[i];
        const Vec3<T> vh = h == kFreePoint ? (p.v[i] + p.a[i] * half) * keep : handle_v[h];
        p.v[i] = vh;
        p.x[i] += vh * dt;
      },
      "knit.kick_drift");
}

template <typename T>
void knit_kick(const exec::Exec& ex, KnitView<T> p, const Vec3<T>* handle_v, T dt, T keep) {
  const T half = T(0.5) * dt;
  exec::for_each(
      ex, p.n,
      [=] KF_HD(std::size_t i) {
        const std::uint32_t h = p.handle[i];
        p.v[i] = h == kFreePoint ? (p.v[i] + p.a[i] * half) * keep : handle_v[h];
      },
      "knit.kick");
}

template <typename T>
double knit_spring_energy(const exec::Exec& ex, KnitView<T> p, const SpringView<T>& s) {
  return exec::transform_reduce(ex, p.n, 0.0, exec::SumOp{}, SpringEnergyEvaluator<T>{p, s},
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
void knit_spring_limits(const exec::Exec& ex, KnitView<T> p, const SpringView<T>& s, T& spring,
                        T& damping) {
  const SpringLimits<T> l = exec::transform_reduce(ex, p.n, SpringLimits<T>{}, LimitsMinOp{},
                                                   SpringLimitEvaluator<T>{p, s}, "knit.limits");
  spring = l.spring;
  damping = l.damping;
}

template <typename T>
std::size_t knit_collide_rigid(const exec::Exec& ex, KnitView<T> p, const RigidShape<T>* shapes,
                               std::size_t n_shapes, T radius, T friction) {
  return exec::transform_reduce(
      ex, p.n, std::size_t(0), exec::SumOp{},
      [=] KF_HD(std::size_t i) -> std::size_t {
        if (p.handle[i] != kFreePoint)
          return 0;
        std::size_t hits = 0;
        for (std::size_t s = 0; s < n_shapes; ++s) {
          Vec3<T> nrm;
          const T d = shapes[s].distance(p.x[i], nrm);
          if (d >= radius)
            continue;
          p.x[i] += nrm * (radius - d);
          const Vec3<T> rel = p.v[i] - shapes[s].velocity;
          const T vn = dot(rel, nrm);
          if (vn < T(0)) {
            const Vec3<T> vt = rel - nrm * vn;
            const T vt_len = norm(vt);
            // Coulomb: the tangential speed drops by friction * |vn|, never past zero.
            const T keep_t = vt_len > T(0) ? kmax(T(0), T(1) - friction * (-vn) / vt_len) : T(0);
            p.v[i] = shapes[s].velocity + vt * keep_t;
          }
          hits = 1;
        }
        return hits;
      },
      "knit.collide_rigid");
}

#define KF_INSTANTIATE(T)                                                                          \
  template void knit_forces<T>(const exec::Exec&, KnitView<T>, const SpringView<T>&, Vec3<T>);     \
  template void knit_kick_drift<T>(const exec::Exec&, KnitView<T>, const Vec3<T>*, T, T);          \
  template void knit_kick<T>(const exec::Exec&, KnitView<T>, const Vec3<T>*, T, T);                \
  template double knit_spring_energy<T>(const exec::Exec&, KnitView<T>, const SpringView<T>&);     \
  template double knit_kinetic_energy<T>(const exec::Exec&, KnitView<T>);                          \
  template double knit_potential_energy<T>(const exec::Exec&, KnitView<T>, Vec3<T>);               \
  template void knit_spring_limits<T>(const exec::Exec&, KnitView<T>, const SpringView<T>&, T&,    \
                                      T&);                                                         \
  template std::size_t knit_collide_rigid<T>(const exec::Exec&, KnitView<T>, const RigidShape<T>*, \
                                             std::size_t, T, T);
KF_INSTANTIATE(float)
KF_INSTANTIATE(double)
#undef KF_INSTANTIATE

} // namespace kf
