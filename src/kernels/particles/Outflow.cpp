#include "kernels/particles/Outflow.hpp"

namespace kf {

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
                                  typename FluidSet<T>::Carry carry) {
  const std::size_t n = fluid.size();
  grid.build_keeping(ex, fluid.x.data(), n, KeepBox<T>{lo, hi}, fluid.id.data());
  fluid.reorder(ex, grid.permutation(), carry); // the outside ones now last, in order
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
                                                  const Vec3<float>&, double*,
                                                  FluidSet<float>::Carry);
template std::size_t sort_removing_outside<double>(const exec::Exec&, NeighbourGrid<double>&,
                                                   FluidSet<double>&, const Vec3<double>&,
                                                   const Vec3<double>&, double*,
                                                   FluidSet<double>::Carry);

} // namespace kf
