#include "kernels/particles/Outflow.hpp"

namespace kf {

template <typename T>
OutflowResult remove_outside(const exec::Exec& ex, FluidSet<T>& fluid,
                             exec::DeviceBuffer<std::uint32_t>& flags, const Vec3<T>& lo,
                             const Vec3<T>& hi) {
  const std::size_t n = fluid.size();
  flags.resize(n);
  const Vec3<T>* x = fluid.x.data();
  const T* m = fluid.m.data();
  std::uint32_t* f = flags.data();
  const double gone = exec::transform_reduce(
      ex, n, 0.0, exec::SumOp{},
      [=] KF_HD(std::size_t j) {
        const Vec3<T> q = x[j];
        // Written so a NaN counts as inside: it stays for the step-size check to report.
        const bool in =
            !(q.x < lo.x || q.x > hi.x || q.y < lo.y || q.y > hi.y || q.z < lo.z || q.z > hi.z);
        f[j] = in ? 1u : 0u;
        return in ? 0.0 : double(m[j]);
      },
      "fluid.outflow");
  OutflowResult r;
  if (gone > 0) {
    r.particles = fluid.keep_flagged(ex, flags);
    r.mass = gone;
  }
  return r;
}

template OutflowResult remove_outside<float>(const exec::Exec&, FluidSet<float>&,
                                             exec::DeviceBuffer<std::uint32_t>&, const Vec3<float>&,
                                             const Vec3<float>&);
template OutflowResult remove_outside<double>(const exec::Exec&, FluidSet<double>&,
                                              exec::DeviceBuffer<std::uint32_t>&,
                                              const Vec3<double>&, const Vec3<double>&);

} // namespace kf
