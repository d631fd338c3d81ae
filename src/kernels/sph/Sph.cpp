#include "kernels/sph/Sph.hpp"

#include "kernels/sph/SmoothingKernels.hpp"
#include "kernels/sph/SphEvaluators_K.hpp"

#include <type_traits>

namespace kf {

template <typename T>
void sph_density(const exec::Exec& ex, const SphParams<T>& prm, FluidView<T> f, CellView<T> cells,
                 const BoundaryNeighbours<T>& b, const ListView<T>& list) {
  exec::for_each(ex, f.n, PackPositionMass<T>{f}, "sph.pack");
  with_kernel<T>(prm.kernel, prm.h, [&](auto k) {
    using K = decltype(k);
    if (list.count)
      exec::for_each(ex, f.n, DensityEvaluator<T, K, SphList<T>>{k, prm.eos, f, {list}, b},
                     "sph.density");
    else
      exec::for_each(ex, f.n, DensityEvaluator<T, K, SphCellWalk<T>>{k, prm.eos, f, {cells, b}, b},
                     "sph.density");
  });
}

template <typename T>
void boundary_pressure(const exec::Exec& ex, const SphParams<T>& prm, BoundaryView<T> b,
                       const FluidView<T>& f, CellView<T> fluid_cells, const RigidShape<T>* shapes,
                       const std::uint8_t* fluid_near, const ListView<T>& walls) {
  auto run = [&](auto k, auto listed) {
    using E = BoundaryPressureEvaluator<T, decltype(k), decltype(listed)::value>;
    exec::for_each(ex, b.n, E{k, prm, b, f, fluid_cells, shapes, fluid_near, walls},
                   "boundary.pressure");
  };
  with_kernel<T>(prm.kernel, prm.h, [&](auto k) {
    if (walls.count)
      run(k, std::true_type{});
    else
      run(k, std::false_type{});
  });
}

template <typename T>
void sph_density_predict(const exec::Exec& ex, const SphParams<T>& prm, FluidView<T> f, T dt) {
  exec::for_each(ex, f.n, DensityPredictor<T>{prm.eos, f, dt}, "sph.predict");
}

template <typename T>
void sph_forces(const exec::Exec& ex, const SphParams<T>& prm, FluidView<T> f, CellView<T> cells,
                const BoundaryNeighbours<T>& b, const ListView<T>& list, T dt) {
  auto run = [&](auto k, auto continuity) {
    using K = decltype(k);
    constexpr bool C = decltype(continuity)::value;
    if (list.count)
      exec::for_each(ex, f.n, ForceEvaluator<T, K, SphList<T>, C>{k, prm, f, {list}, b, dt},
                     "sph.forces");
    else
      exec::for_each(ex, f.n, ForceEvaluator<T, K, SphCellWalk<T>, C>{k, prm, f, {cells, b}, b, dt},
                     "sph.forces");
  };
  with_kernel<T>(prm.kernel, prm.h, [&](auto k) {
    if (prm.density == DensityModel::Continuity)
      run(k, std::true_type{});
    else
      run(k, std::false_type{});
  });
}

#define KF_INSTANTIATE(T)                                                                          \
  template void sph_density<T>(const exec::Exec&, const SphParams<T>&, FluidView<T>, CellView<T>,  \
                               const BoundaryNeighbours<T>&, const ListView<T>&);                  \
  template void boundary_pressure<T>(const exec::Exec&, const SphParams<T>&, BoundaryView<T>,      \
                                     const FluidView<T>&, CellView<T>, const RigidShape<T>*,       \
                                     const std::uint8_t*, const ListView<T>&);                     \
  template void sph_density_predict<T>(const exec::Exec&, const SphParams<T>&, FluidView<T>, T);   \
  template void sph_forces<T>(const exec::Exec&, const SphParams<T>&, FluidView<T>, CellView<T>,   \
                              const BoundaryNeighbours<T>&, const ListView<T>&, T);
KF_INSTANTIATE(float)
KF_INSTANTIATE(double)
#undef KF_INSTANTIATE

} // namespace kf
