#include "domain/PartitionPlan.hpp"

#include "kernels/grid/NeighbourGrid.hpp"
#include "kernels/grid/RankSelection.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <optional>
#include <set>

namespace kf {

std::array<std::size_t, kPhases> ghost_bytes_per_step(const Scene& scene) {
  const std::size_t t = scene.precision == Precision::Double ? 8 : 4;
  bool moving = false;
  for (const auto& o : scene.obstacles)
    moving = moving || o.velocity.x != 0 || o.velocity.y != 0 || o.velocity.z != 0;
  std::array<std::size_t, kPhases> b{0, 0, 0};
  b[static_cast<int>(Phase::Fluid)] = (3 + 3 + 1 + 1) * t;
  b[static_cast<int>(Phase::Boundary)] = (moving ? 3 : 0) * t;
  b[static_cast<int>(Phase::Knit)] =
      std::size_t(scene.knit.substeps) * 6 * t + (scene.has(Module::Capillary) ? t : 0);
  return b;
}

template <typename T>
PartitionReport describe_partition(const Scene& scene, const Decomposition& d, const HaloWidths& w,
                                   const PhaseCosts& costs,
                                   const std::array<std::span<const Vec3<T>>, kPhases>& x,
                                   const GridGeometry<T>* whole) {
  PartitionReport r;
  const int ranks = d.ranks();
  r.ranks = ranks;
  r.widths = w;
  r.costs = costs;
  const BlockGrid& grid = d.grid();
  r.block_edge = grid.edge();
  r.blocks[0] = grid.nx();
  r.blocks[1] = grid.ny();
  r.blocks[2] = grid.nz();
  std::vector<std::array<double, kPhases>> counts(grid.count(), {0, 0, 0});
  for (int p = 0; p < kPhases; ++p)
    for (const Vec3<T>& q : x[p])
      counts[grid.block_of(vec_cast<double>(q))][p] += 1;
  const auto per = d.rank_costs(counts, costs);
  r.imbalance = Decomposition::imbalance(per);
  r.rank.resize(ranks);
  const auto bytes = ghost_bytes_per_step(scene);
  // The fluid beside walls goes as far as w.walls: the run's rule (RankExchange), by the
  // boundary grid's cells (the whole grid's) with boundary particles in the cells a walk from
  // them visits.
  const auto& xb = x[static_cast<int>(Phase::Boundary)];
  const exec::Exec host{exec::Backend::Cpu};
  std::optional<NeighbourGrid<T>> walls;
  exec::DeviceBuffer<std::uint8_t> near(exec::Backend::Cpu, 0, "plan.beside_walls");
  if (w.walls > 0 && !xb.empty() && whole) {
    walls.emplace(exec::Backend::Cpu, *whole, static_cast<int>(scene.solver.cell_span));
    walls->build(host, xb.data(), xb.size());
    walls->occupied_around(host, near);
  }
  const WiderCells<T> beside{walls ? walls->geometry() : GridGeometry<T>{},
                             walls ? near.data() : nullptr, w.walls};
  const std::array<double, kPhases> width{w.fluid, w.boundary, w.knit};
  std::vector<std::set<int>> sources(ranks);
  std::vector<int> to;
  for (int p = 0; p < kPhases; ++p)
    for (const Vec3<T>& qt : x[p]) {
      const Vec3d q = vec_cast<double>(qt);
      const int own = d.owner(q);
      ++r.rank[own].owned[p];
      d.ghost_ranks(
          q, p == static_cast<int>(Phase::Fluid) ? beside.width_at(qt, width[p]) : width[p], to);
      for (int g : to) {
        ++r.rank[g].ghosts[p];
        r.rank[g].bytes_per_step += bytes[p];
        sources[g].insert(own);
      }
    }
  for (int k = 0; k < ranks; ++k) {
    r.rank[k].cost = per[k];
    r.rank[k].neighbours = static_cast<int>(sources[k].size());
  }
  // Each rank's window of the run's grids (SimulationT::fit_grids_to_region).
  if (whole) {
    r.domain_cells = whole->cells();
    for (int k = 0; k < ranks; ++k)
      r.rank[k].grid_cells = rank_grid(d, k, *whole, w).cells();
  }
  return r;
}

template PartitionReport
describe_partition<float>(const Scene&, const Decomposition&, const HaloWidths&, const PhaseCosts&,
                          const std::array<std::span<const Vec3<float>>, kPhases>&,
                          const GridGeometry<float>*);
template PartitionReport
describe_partition<double>(const Scene&, const Decomposition&, const HaloWidths&, const PhaseCosts&,
                           const std::array<std::span<const Vec3<double>>, kPhases>&,
                           const GridGeometry<double>*);

} // namespace kf
