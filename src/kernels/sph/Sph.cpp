#include "kernels/sph/Sph.hpp"

#include "kernels/sph/SmoothingKernels.hpp"
#include "kernels/sph/SphEvaluators_K.hpp"

#include <type_traits>

namespace kf {

template <typename T>
void sph_pack(const exec::Exec& ex, FluidView<T> f) {
  exec::for_each(ex, f.n, PackPositionMass<T>{f}, "sph.pack");
}

template <typename T>
void sph_density_rows(const exec::Exec& ex, const SphParams<T>& prm, FluidView<T> f,
                      CellView<T> cells, const BoundaryNeighbours<T>& b, const ListView<T>& list,
                      const exec::Rows& rows) {
  with_kernel<T>(prm.kernel, prm.h, [&](auto k) {
    using K = decltype(k);
    if (list.count)
      exec::for_rows(ex, rows, DensityEvaluator<T, K, SphList<T>>{k, prm.eos, f, {list}, b},
                     "sph.density");
    else
      exec::for_rows(ex, rows, DensityEvaluator<T, K, SphCellWalk<T>>{k, prm.eos, f, {cells, b}, b},
                     "sph.density");
  });
}

template <typename T>
void sph_density(const exec::Exec& ex, const SphParams<T>& prm, FluidView<T> f, CellView<T> cells,
                 const BoundaryNeighbours<T>& b, const ListView<T>& list) {
  sph_pack(ex, f);
  sph_density_rows(ex, prm, f, cells, b, list, exec::Rows{nullptr, f.n});
}

template <typename T>
void boundary_pressure(const exec::Exec& ex, const SphParams<T>& prm, BoundaryView<T> b,
                       const FluidView<T>& f, CellView<T> fluid_cells, const RigidShape<T>* shapes,
                       const std::uint8_t* fluid_near, const ListView<T>& walls,
                       const exec::Rows* rows, bool dry_written) {
  const exec::Rows over = rows ? *rows : exec::Rows{nullptr, b.n};
  auto run = [&](auto k, auto listed) {
    using E = BoundaryPressureEvaluator<T, decltype(k), decltype(listed)::value>;
    exec::for_rows(ex, over, E{k, prm, b, f, fluid_cells, shapes, fluid_near, walls, dry_written},
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
                const BoundaryNeighbours<T>& b, const ListView<T>& list, T dt,
                const exec::Rows* rows) {
  const exec::Rows over = rows ? *rows : exec::Rows{nullptr, f.n};
  auto run = [&](auto k, auto continuity, auto artificial) {
    using K = decltype(k);
    constexpr bool C = decltype(continuity)::value, A = decltype(artificial)::value;
    if (list.count)
      exec::for_rows(ex, over, ForceEvaluator<T, K, SphList<T>, C, A>{k, prm, f, {list}, b, dt},
                     "sph.forces");
    else
      exec::for_rows(ex, over,
                     ForceEvaluator<T, K, SphCellWalk<T>, C, A>{k, prm, f, {cells, b}, b, dt},
                     "sph.forces");
  };
  // Without the artificial viscosity the pass is the one it was (its own instantiation).
  auto with_artificial = [&](auto k, auto continuity) {
    if (prm.artificial > T(0))
      run(k, continuity, std::true_type{});
    else
      run(k, continuity, std::false_type{});
  };
  with_kernel<T>(prm.kernel, prm.h, [&](auto k) {
    if (prm.density == DensityModel::Continuity)
      with_artificial(k, std::true_type{});
    else
      with_artificial(k, std::false_type{});
  });
}

template <typename T>
void sph_mover_work(const exec::Exec& ex, const SphParams<T>& prm, const FluidView<T>& f,
                    const BoundaryNeighbours<T>& b, const std::uint32_t* owned, T dt,
                    double* work) {
  if (b.n == 0 || !b.obstacle || !b.shapes)
    return;
  with_kernel<T>(prm.kernel, prm.h, [&](auto k) {
    exec::transform_reduce_into(ex, f.n, exec::SumOp{},
                                MoverWorkEvaluator<T, decltype(k)>{k, prm, f, b, owned, dt}, work,
                                "boundary.work");
  });
}

#define KF_INSTANTIATE(T)                                                                          \
  template void sph_density<T>(const exec::Exec&, const SphParams<T>&, FluidView<T>, CellView<T>,  \
                               const BoundaryNeighbours<T>&, const ListView<T>&);                  \
  template void sph_pack<T>(const exec::Exec&, FluidView<T>);                                      \
  template void sph_density_rows<T>(const exec::Exec&, const SphParams<T>&, FluidView<T>,          \
                                    CellView<T>, const BoundaryNeighbours<T>&, const ListView<T>&, \
                                    const exec::Rows&);                                            \
  template void boundary_pressure<T>(                                                              \
      const exec::Exec&, const SphParams<T>&, BoundaryView<T>, const FluidView<T>&, CellView<T>,   \
      const RigidShape<T>*, const std::uint8_t*, const ListView<T>&, const exec::Rows*, bool);     \
  template void sph_density_predict<T>(const exec::Exec&, const SphParams<T>&, FluidView<T>, T);   \
  template void sph_forces<T>(const exec::Exec&, const SphParams<T>&, FluidView<T>, CellView<T>,   \
                              const BoundaryNeighbours<T>&, const ListView<T>&, T,                 \
                              const exec::Rows*);                                                  \
  template void sph_mover_work<T>(const exec::Exec&, const SphParams<T>&, const FluidView<T>&,     \
                                  const BoundaryNeighbours<T>&, const std::uint32_t*, T, double*);
KF_INSTANTIATE(float)
KF_INSTANTIATE(double)
#undef KF_INSTANTIATE

} // namespace kf
