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

namespace {

template <typename T>
struct MassAt {
  const T* m;
  KF_HD KF_INLINE double operator()(std::size_t k) const { return double(m[k]); }
};

} // namespace

template <typename T>
std::size_t sort_removing_outside(const exec::Exec& ex, NeighbourGrid<T>& grid, FluidSet<T>& fluid,
                                  const Vec3<T>& lo, const Vec3<T>& hi, double* mass,
                                  bool acceleration) {
  const std::size_t n = fluid.size();
  grid.build_keeping(ex, fluid.x.data(), n, KeepBox<T>{lo, hi});
  fluid.reorder(ex, grid.permutation(), acceleration); // the outside ones now last, in order
  const std::size_t kept = grid.kept();
  if (kept == n)
    return 0;
  exec::transform_reduce_into(ex, n - kept, exec::SumOp{}, MassAt<T>{fluid.m.data() + kept}, mass,
                              "fluid.outflow");
  grid.drop_outside(kept);
  fluid.resize(kept);
  return n - kept;
}

template std::size_t sort_removing_outside<float>(const exec::Exec&, NeighbourGrid<float>&,
                                                  FluidSet<float>&, const Vec3<float>&,
                                                  const Vec3<float>&, double*, bool);
template std::size_t sort_removing_outside<double>(const exec::Exec&, NeighbourGrid<double>&,
                                                   FluidSet<double>&, const Vec3<double>&,
                                                   const Vec3<double>&, double*, bool);
template OutflowResult remove_outside<float>(const exec::Exec&, FluidSet<float>&,
                                             exec::DeviceBuffer<std::uint32_t>&, const Vec3<float>&,
                                             const Vec3<float>&);
template OutflowResult remove_outside<double>(const exec::Exec&, FluidSet<double>&,
                                              exec::DeviceBuffer<std::uint32_t>&,
                                              const Vec3<double>&, const Vec3<double>&);

} // namespace kf
