#include "kernels/integrate/Verlet.hpp"

#include "core/Math.hpp"

namespace kf {

template <typename T>
void kick_drift(const exec::Exec& ex, Vec3<T>* x, Vec3<T>* v, const Vec3<T>* a, std::size_t n, T dt,
                T keep, const char* label, Prescribed<T> fixed, const double* dt_device) {
  exec::for_each(
      ex, n,
      [=] KF_HD(std::size_t i) {
        const T step = drift_step(dt, dt_device);
        const Vec3<T> vh = half_kick(i, v, a, T(0.5) * step, keep, fixed);
        v[i] = vh;
        x[i] += vh * step;
      },
      label);
}

template <typename T>
void kick(const exec::Exec& ex, Vec3<T>* v, const Vec3<T>* a, std::size_t n, T dt, T keep,
          const char* label, Prescribed<T> fixed) {
  const T half = T(0.5) * dt;
  exec::for_each(
      ex, n, [=] KF_HD(std::size_t i) { v[i] = half_kick(i, v, a, half, keep, fixed); }, label);
}

// Max that lets NaN win, so a blown-up particle cannot hide from the step-size control.
struct NanMaxOp {
  template <typename T>
  KF_HD KF_INLINE MotionBounds<T> operator()(const MotionBounds<T>& p,
                                             const MotionBounds<T>& q) const {
    return {nan_max(p.v2, q.v2), nan_max(p.a2, q.a2)};
  }
};

template <typename T>
struct MotionOf {
  const Vec3<T>* v;
  const Vec3<T>* a;
  KF_HD KF_INLINE MotionBounds<T> operator()(std::size_t i) const {
    return {norm2(v[i]), norm2(a[i])};
  }
};

template <typename T>
MotionBounds<T> motion_bounds(const exec::Exec& ex, const Vec3<T>* v, const Vec3<T>* a,
                              std::size_t n, const char* label) {
  return exec::transform_reduce(ex, n, MotionBounds<T>{}, NanMaxOp{}, MotionOf<T>{v, a}, label);
}

template <typename T>
void motion_bounds_to(const exec::Exec& ex, const Vec3<T>* v, const Vec3<T>* a, std::size_t n,
                      MotionBounds<T>* out, const char* label) {
  exec::transform_reduce_to(ex, n, MotionBounds<T>{}, NanMaxOp{}, MotionOf<T>{v, a}, out, label);
}

template <typename T>
struct KickMotion {
  Vec3<T>* v;
  const Vec3<T>* a;
  T half, keep;
  KF_HD KF_INLINE MotionBounds<T> operator()(std::size_t i) const {
    const Vec3<T> vn = half_kick(i, v, a, half, keep, Prescribed<T>{});
    v[i] = vn; // each index is visited exactly once on either backend
    return {norm2(vn), norm2(a[i])};
  }
};

/// KickMotion of the rows flagged in `only`; the others neither move nor bound.
template <typename T>
struct KickMotionOf {
  KickMotion<T> kick;
  const std::uint32_t* only;
  KF_HD KF_INLINE MotionBounds<T> operator()(std::size_t i) const {
    return only[i] ? kick(i) : MotionBounds<T>{T(0), T(0)};
  }
};

template <typename T>
void kick_bounds(const exec::Exec& ex, Vec3<T>* v, const Vec3<T>* a, std::size_t n, T dt, T keep,
                 MotionBounds<T>* out, const char* label, const std::uint32_t* only) {
  const KickMotion<T> k{v, a, T(0.5) * dt, keep};
  if (only)
    exec::transform_reduce_to(ex, n, MotionBounds<T>{}, NanMaxOp{}, KickMotionOf<T>{k, only}, out,
                              label);
  else
    exec::transform_reduce_to(ex, n, MotionBounds<T>{}, NanMaxOp{}, k, out, label);
}

template <typename T>
void kick_rows(const exec::Exec& ex, Vec3<T>* v, const Vec3<T>* a, const exec::Rows& rows, T dt,
               T keep, const char* label) {
  const T half = T(0.5) * dt;
  exec::for_rows(
      ex, rows,
      [=] KF_HD(std::size_t i) { v[i] = half_kick(i, v, a, half, keep, Prescribed<T>{}); }, label);
}

#define KF_INSTANTIATE(T)                                                                          \
  template void kick_drift<T>(const exec::Exec&, Vec3<T>*, Vec3<T>*, const Vec3<T>*, std::size_t,  \
                              T, T, const char*, Prescribed<T>, const double*);                    \
  template void kick<T>(const exec::Exec&, Vec3<T>*, const Vec3<T>*, std::size_t, T, T,            \
                        const char*, Prescribed<T>);                                               \
  template MotionBounds<T> motion_bounds<T>(const exec::Exec&, const Vec3<T>*, const Vec3<T>*,     \
                                            std::size_t, const char*);                             \
  template void motion_bounds_to<T>(const exec::Exec&, const Vec3<T>*, const Vec3<T>*,             \
                                    std::size_t, MotionBounds<T>*, const char*);                   \
  template void kick_bounds<T>(const exec::Exec&, Vec3<T>*, const Vec3<T>*, std::size_t, T, T,     \
                               MotionBounds<T>*, const char*, const std::uint32_t*);               \
  template void kick_rows<T>(const exec::Exec&, Vec3<T>*, const Vec3<T>*, const exec::Rows&, T, T, \
                             const char*);
KF_INSTANTIATE(float)
KF_INSTANTIATE(double)
#undef KF_INSTANTIATE

} // namespace kf
