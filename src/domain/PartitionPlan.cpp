#include "domain/PartitionPlan.hpp"

#include "domain/KnitBuilder.hpp"
#include "domain/Samplers.hpp"
#include "kernels/grid/NeighbourGrid.hpp"
#include "kernels/grid/RankSelection.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <optional>
#include <set>

namespace kf {

GhostWidths ghost_widths(const Scene& scene, double longest_spring, double self_radius,
                         double coupling_reach) {
  GhostWidths g;
  if (scene.has(Module::Fluid)) {
    double h = scene.support_radius();
    if (scene.solver.neighbour_list == Scene::Solver::NeighbourLists::Verlet)
      h *= 1 + scene.solver.neighbour_skin;
    g.width[static_cast<int>(Phase::Fluid)] = std::max(h, coupling_reach);
    if (scene.has(Module::Boundary)) {
      g.width[static_cast<int>(Phase::Boundary)] = h;
      g.fluid_beside_walls = std::max(2 * h, g.of(Phase::Fluid)); // as RankExchange's
    }
  }
  if (scene.has(Module::Knit))
    g.width[static_cast<int>(Phase::Knit)] =
        std::max({1.5 * longest_spring, 2 * self_radius, coupling_reach});
  return g;
}

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

PartitionReport plan_partition(const Scene& scene, const std::array<std::vector<Vec3d>, kPhases>& x,
                               const GhostWidths& widths, int ranks) {
  PartitionReport r;
  r.ranks = ranks;
  r.widths = widths;
  r.costs.knit_substeps = scene.knit.substeps;
  // Blocks of block_cells support radii (the knit's contact reach where there is no fluid).
  const double cell =
      scene.has(Module::Fluid) ? scene.support_radius() : std::max(widths.of(Phase::Knit), 1e-6);
  r.block_edge = scene.parallel.block_cells * cell;
  // The box the blocks cover: the domain, widened to every particle (knit may start outside it).
  Vec3d lo = scene.domain.min, hi = scene.domain.max;
  for (const auto& phase : x)
    for (const Vec3d& q : phase)
      for (int d = 0; d < 3; ++d) {
        (&lo.x)[d] = std::min((&lo.x)[d], (&q.x)[d]);
        (&hi.x)[d] = std::max((&hi.x)[d], (&q.x)[d]);
      }
  const BlockGrid grid(lo, hi, r.block_edge);
  r.blocks[0] = grid.nx();
  r.blocks[1] = grid.ny();
  r.blocks[2] = grid.nz();
  std::vector<std::array<double, kPhases>> counts(grid.count(), {0, 0, 0});
  for (int p = 0; p < kPhases; ++p)
    for (const Vec3d& q : x[p])
      counts[grid.block_of(q)][p] += 1;
  const double widest = *std::max_element(widths.width.begin(), widths.width.end());
  const Decomposition d = Decomposition::partition(grid, counts, r.costs, ranks, widest);
  const auto per = d.rank_costs(counts, r.costs);
  r.imbalance = Decomposition::imbalance(per);
  r.rank.resize(ranks);
  const auto bytes = ghost_bytes_per_step(scene);
  // The fluid beside walls goes as far as fluid_beside_walls: the run's rule (RankExchange),
  // by the run's cells (the fluid grid's: support + skin over the span) with boundary
  // particles in the cells a walk from them visits.
  const auto& xb = x[static_cast<int>(Phase::Boundary)];
  const exec::Exec host{exec::Backend::Cpu};
  std::optional<NeighbourGrid<double>> walls;
  exec::DeviceBuffer<std::uint8_t> near(exec::Backend::Cpu, 0, "plan.beside_walls");
  if (widths.fluid_beside_walls > 0 && !xb.empty()) {
    const int span = static_cast<int>(scene.solver.cell_span);
    walls.emplace(exec::Backend::Cpu,
                  NeighbourGrid<double>::cover(scene.domain.min, scene.domain.max,
                                               widths.of(Phase::Boundary) / span, span),
                  span);
    walls->build(host, xb.data(), xb.size());
    walls->occupied_around(host, near);
  }
  const WiderCells<double> beside{walls ? walls->geometry() : GridGeometry<double>{},
                                  walls ? near.data() : nullptr, widths.fluid_beside_walls};
  std::vector<std::set<int>> sources(ranks);
  std::vector<int> to;
  for (int p = 0; p < kPhases; ++p)
    for (const Vec3d& q : x[p]) {
      const int own = d.owner(q);
      ++r.rank[own].owned[p];
      d.ghost_ranks(q,
                    p == static_cast<int>(Phase::Fluid) ? beside.width_at(q, widths.width[p])
                                                        : widths.width[p],
                    to);
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
  // The run's grids (SimulationT: cells of the support plus the lists' skin over the span) and
  // each rank's window of them.
  if (scene.has(Module::Fluid) || scene.has(Module::Boundary)) {
    const double h = scene.support_radius();
    const double skin = scene.solver.neighbour_list == Scene::Solver::NeighbourLists::Verlet
                            ? scene.solver.neighbour_skin * h
                            : 0.0;
    const int span = static_cast<int>(scene.solver.cell_span);
    const auto whole =
        NeighbourGrid<double>::cover(scene.domain.min, scene.domain.max, (h + skin) / span, span);
    r.domain_cells = whole.cells();
    const double margin =
        std::max({widths.of(Phase::Fluid), widths.of(Phase::Boundary), widths.fluid_beside_walls}) +
        skin;
    for (int k = 0; k < ranks; ++k) {
      const auto [wlo, whi] =
          d.window(k, whole.origin, whole.cell, {whole.nx, whole.ny, whole.nz}, margin);
      r.rank[k].grid_cells = std::size_t(whi[0] - wlo[0] + 1) * std::size_t(whi[1] - wlo[1] + 1) *
                             std::size_t(whi[2] - wlo[2] + 1);
    }
  }
  return r;
}

PartitionReport plan_partition(const Scene& scene, const PlanReport& plan, int ranks) {
  std::array<std::vector<Vec3d>, kPhases> x;
  if (scene.has(Module::Fluid))
    x[static_cast<int>(Phase::Fluid)] = sample_fluid(scene).x;
  if (scene.has(Module::Boundary))
    x[static_cast<int>(Phase::Boundary)] =
        sample_boundaries(scene, scene.fluid.spacing, scene.support_radius()).x;
  double longest = 0;
  if (scene.has(Module::Knit)) {
    KnitMesh mesh = build_knit(scene);
    for (const Spring& s : mesh.springs)
      longest = std::max(longest, s.rest);
    x[static_cast<int>(Phase::Knit)] = std::move(mesh.x);
  }
  const GhostWidths w = ghost_widths(scene, longest, plan.knit_self_radius, plan.coupling_reach);
  return plan_partition(scene, x, w, ranks);
}

} // namespace kf
