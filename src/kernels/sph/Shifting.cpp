#include "kernels/sph/Shifting.hpp"

#include "kernels/sph/SmoothingKernels.hpp"

namespace kf {

template <typename T>
void sph_shift(const exec::Exec& ex, const SphParams<T>& prm, const FluidView<T>& f,
               CellView<T> cells, const BoundaryNeighbours<T>& b, const ListView<T>& list,
               const ShiftRule<T>& rule, const exec::Rows& rows, Vec3<T>* shift) {
  with_kernel<T>(prm.kernel, prm.h, [&](auto k) {
    using K = decltype(k);
    if (list.count)
      exec::for_rows(ex, rows, ShiftEvaluator<T, K, SphList<T>>{k, f, {list}, b, rule, shift},
                     "sph.shift");
    else
      exec::for_rows(ex, rows,
                     ShiftEvaluator<T, K, SphCellWalk<T>>{k, f, {cells, b}, b, rule, shift},
                     "sph.shift");
  });
}

template <typename T>
void sph_apply_shift(const exec::Exec& ex, FluidView<T> f, const exec::Rows& rows,
                     const Vec3<T>* shift) {
  exec::for_rows(ex, rows, ApplyShift<T>{f.x, shift}, "sph.shift");
}

#define KF_INSTANTIATE(T)                                                                          \
  template void sph_shift<T>(const exec::Exec&, const SphParams<T>&, const FluidView<T>&,          \
                             CellView<T>, const BoundaryNeighbours<T>&, const ListView<T>&,        \
                             const ShiftRule<T>&, const exec::Rows&, Vec3<T>*);                    \
  template void sph_apply_shift<T>(const exec::Exec&, FluidView<T>, const exec::Rows&,             \
                                   const Vec3<T>*);
KF_INSTANTIATE(float)
KF_INSTANTIATE(double)
#undef KF_INSTANTIATE

} // namespace kf
