#pragma once
// Points in a neighbour grid's order, as the solver keeps its particles: the grid is built over
// them (its permutation and tables then describe the sorted points) and the host copy is sorted.
#include "core/Vec3.hpp"
#include "kernels/exec/Algorithms.hpp"
#include "kernels/exec/DeviceBuffer.hpp"
#include "kernels/grid/NeighbourGrid.hpp"

#include <vector>

namespace kf::test {

template <typename T>
std::vector<Vec3<T>> in_grid_order(NeighbourGrid<T>& grid, const exec::Exec& ex,
                                   const std::vector<Vec3<T>>& pts) {
  exec::DeviceBuffer<Vec3<T>> x(ex.backend);
  x.assign(pts);
  grid.build(ex, x.data(), pts.size());
  const auto perm = grid.permutation().to_host();
  std::vector<Vec3<T>> sorted(pts.size());
  for (std::size_t k = 0; k < pts.size(); ++k)
    sorted[k] = pts[perm[k]];
  return sorted;
}

} // namespace kf::test
