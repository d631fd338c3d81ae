#pragma once
// Particle shifting (Scene::Solver::shifting): each fluid particle moved towards where its
// neighbours are sparser, which keeps the particles' arrangement even as the flow shears it.
#include "kernels/exec/Algorithms.hpp"
#include "kernels/sph/Shifting_K.hpp"
#include "kernels/sph/Sph.hpp"

namespace kf {

/// The shift of each particle `rows` names into shift[i] (ShiftEvaluator), from the fluid's
/// gather copies (xm, vol: after the density pass at the same positions) and the boundary
/// particles; neighbours from `list` when it has counts, else the grids. Moves nothing.
template <typename T>
void sph_shift(const exec::Exec& ex, const SphParams<T>& prm, const FluidView<T>& f,
               CellView<T> cells, const BoundaryNeighbours<T>& b, const ListView<T>& list,
               const ShiftRule<T>& rule, const exec::Rows& rows, Vec3<T>* shift);

/// x_i += shift_i over `rows`.
template <typename T>
void sph_apply_shift(const exec::Exec& ex, FluidView<T> f, const exec::Rows& rows,
                     const Vec3<T>* shift);

} // namespace kf
