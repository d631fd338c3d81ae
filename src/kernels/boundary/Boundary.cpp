#include "kernels/boundary/Boundary.hpp"

#include "kernels/boundary/RigidContact_K.hpp"

namespace kf {

template <typename T>
void move_boundary(const exec::Exec& ex, BoundaryView<T> b, const RigidShape<T>* shapes) {
  exec::for_each(
      ex, b.n,
      [=] KF_HD(std::size_t i) {
        const std::uint32_t o = b.obstacle[i];
        b.x[i] = o == kWallObstacle ? b.x0[i] : b.x0[i] + shapes[o].offset;
      },
      "boundary.move");
}

template <typename T>
void enforce_rigid_shapes(const exec::Exec& ex, Vec3<T>* x, Vec3<T>* v, std::size_t n,
                          const RigidShape<T>* shapes, std::size_t n_shapes, T margin, T friction,
                          const std::uint32_t* fixed, std::uint64_t* count, const char* label,
                          ContactWork<T> work) {
  // A reduction whose functor also corrects the point (each index is visited exactly once on
  // either backend); the sum stays in device memory.
  exec::transform_reduce_into(
      ex, n, exec::SumOp{}, RigidContact<T>{x, v, shapes, n_shapes, margin, friction, fixed, work},
      count, label);
}

namespace {

template <typename T>
struct KickDriftContact {
  Vec3<T>* x;
  Vec3<T>* v;
  const Vec3<T>* a;
  T dt, keep;
  bool close_previous;
  Prescribed<T> fixed;
  RigidContact<T> contact;
  const double* dt_device;
  const std::uint32_t* counted;

  KF_HD std::uint64_t operator()(std::size_t i) const {
    const T step = drift_step(dt, dt_device);
    const T half = T(0.5) * step;
    if (close_previous)
      v[i] = half_kick(i, v, a, half, keep, fixed);
    const Vec3<T> vh = half_kick(i, v, a, half, keep, fixed);
    v[i] = vh;
    x[i] += vh * step;
    const std::uint64_t put_back = contact.n_shapes ? contact(i) : 0;
    return counted && !counted[i] ? 0 : put_back;
  }
};

} // namespace

template <typename T>
void kick_drift_contact(const exec::Exec& ex, Vec3<T>* x, Vec3<T>* v, const Vec3<T>* a,
                        std::size_t n, T dt, T keep, bool close_previous, Prescribed<T> fixed,
                        const RigidShape<T>* shapes, std::size_t n_shapes, T margin, T friction,
                        std::uint64_t* count, const char* label, const double* dt_device,
                        const std::uint32_t* counted, ContactWork<T> work) {
  exec::transform_reduce_into(ex, n, exec::SumOp{},
                              KickDriftContact<T>{x, v, a, dt, keep, close_previous, fixed,
                                                  RigidContact<T>{x, v, shapes, n_shapes, margin,
                                                                  friction, fixed.handle, work},
                                                  dt_device, counted},
                              count, label);
}

template <typename T>
T min_rigid_distance(const exec::Exec& ex, const Vec3<T>* x, std::size_t n,
                     const RigidShape<T>* shapes, std::size_t n_shapes) {
  return exec::transform_reduce(
      ex, n, T(1e30), exec::MinOp{},
      [=] KF_HD(std::size_t i) {
        T best = T(1e30);
        for (std::size_t s = 0; s < n_shapes; ++s) {
          Vec3<T> nrm;
          const T d = shapes[s].distance(x[i], nrm);
          best = d < best ? d : best;
        }
        return best;
      },
      "boundary.min_distance");
}

#define KF_INSTANTIATE(T)                                                                          \
  template void move_boundary<T>(const exec::Exec&, BoundaryView<T>, const RigidShape<T>*);        \
  template void enforce_rigid_shapes<T>(                                                           \
      const exec::Exec&, Vec3<T>*, Vec3<T>*, std::size_t, const RigidShape<T>*, std::size_t, T, T, \
      const std::uint32_t*, std::uint64_t*, const char*, ContactWork<T>);                          \
  template void kick_drift_contact<T>(                                                             \
      const exec::Exec&, Vec3<T>*, Vec3<T>*, const Vec3<T>*, std::size_t, T, T, bool,              \
      Prescribed<T>, const RigidShape<T>*, std::size_t, T, T, std::uint64_t*, const char*,         \
      const double*, const std::uint32_t*, ContactWork<T>);                                        \
  template T min_rigid_distance<T>(const exec::Exec&, const Vec3<T>*, std::size_t,                 \
                                   const RigidShape<T>*, std::size_t);
KF_INSTANTIATE(float)
KF_INSTANTIATE(double)
#undef KF_INSTANTIATE

} // namespace kf
