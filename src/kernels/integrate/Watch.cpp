#include "kernels/integrate/Watch.hpp"

#include "core/Math.hpp"

namespace kf {

namespace {

struct WatchOp {
  KF_HD KF_INLINE WatchSums operator()(const WatchSums& p, const WatchSums& q) const {
    return {p.mass + q.mass, p.kinetic + q.kinetic, p.potential + q.potential,
            nan_max(p.max_speed2, q.max_speed2), nan_max(p.max_density, q.max_density)};
  }
};

template <typename T>
struct WatchOf {
  const Vec3<T>* x;
  const Vec3<T>* v;
  const T* m;
  const T* rho;
  const std::uint32_t* owned;
  Vec3<T> g, ref;
  KF_HD KF_INLINE WatchSums operator()(std::size_t i) const {
    const double v2 = double(norm2(v[i]));
    WatchSums s;
    s.max_speed2 = v2; // a ghost is its owner's copy: the maxima may count it, the sums not
    s.max_density = rho ? double(rho[i]) : 0.0;
    if (!owned || owned[i]) {
      s.mass = double(m[i]);
      s.kinetic = 0.5 * double(m[i]) * v2;
      s.potential = -double(m[i]) * double(dot(g, x[i] - ref));
    }
    return s;
  }
};

} // namespace

template <typename T>
void watch_sums_to(const exec::Exec& ex, const Vec3<T>* x, const Vec3<T>* v, const T* m,
                   const T* rho, const std::uint32_t* owned, std::size_t n, Vec3<T> g, Vec3<T> ref,
                   WatchSums* out, const char* label) {
  exec::transform_reduce_to(ex, n, WatchSums{}, WatchOp{}, WatchOf<T>{x, v, m, rho, owned, g, ref},
                            out, label);
}

template void watch_sums_to<float>(const exec::Exec&, const Vec3<float>*, const Vec3<float>*,
                                   const float*, const float*, const std::uint32_t*, std::size_t,
                                   Vec3<float>, Vec3<float>, WatchSums*, const char*);
template void watch_sums_to<double>(const exec::Exec&, const Vec3<double>*, const Vec3<double>*,
                                    const double*, const double*, const std::uint32_t*, std::size_t,
                                    Vec3<double>, Vec3<double>, WatchSums*, const char*);

} // namespace kf
