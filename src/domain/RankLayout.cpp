#include "domain/RankLayout.hpp"

#include "comm/MpiContext.hpp"

#include "kernels/grid/NeighbourGrid.hpp"

namespace kf {

HaloWidths halo_widths(const Scene& scene, const SplitInputs& in) {
  HaloWidths w;
  const bool fluid = scene.has(Module::Fluid);
  const double h = scene.support_radius();
  const bool verlet = scene.solver.neighbour_list == Scene::Solver::NeighbourLists::Verlet;
  // Ghosts are kept from one sort to the next only with "verlet" lists and fluid.
  w.skin = verlet && fluid ? in.skin : 0.0;
  if (fluid) // A pair within the support now was within support + skin at the sort.
    w.fluid = std::max(h, in.coupling_reach) + w.skin;
  // The owned fluid strays up to the skin out of the region between sorts.
  if (scene.has(Module::Boundary))
    w.boundary = h + w.skin;
  // A ghost wall (within w.boundary of the region) computes its own pressure from the fluid
  // within the support (+ skin: its list's reach) of it, so the fluid beside walls goes twice
  // as far: no exchange of the walls' pressures, one meeting of the ranks a step fewer.
  w.walls = scene.has(Module::Boundary) && fluid ? std::max(w.fluid, 2 * w.boundary) : 0.0;
  if (scene.has(Module::Knit))
    w.knit = in.knit_width + knit_ghost_skin(in.knit_width, in.knit_skin);
  // Blocks of block_cells fluid ghost widths; the knit's reach where there is no fluid.
  const double scale = fluid ? w.fluid : std::max(in.knit_width, 1e-6);
  w.block = scene.parallel.block_cells * scale;
  w.halo_weight = scale;
  return w;
}

PointShares point_shares(const comm::MpiContext& mpi) {
  PointShares over;
  over.box = [&mpi](Vec3d& lo, Vec3d& hi) {
    mpi.min_in_place({&lo.x, 3});
    mpi.max_in_place({&hi.x, 3});
  };
  over.counts = [&mpi](std::vector<std::array<double, kPhases>>& c) {
    mpi.sum_in_place({c.data()->data(), c.size() * kPhases});
  };
  return over;
}

PhaseCosts initial_costs(const Scene& scene) {
  PhaseCosts c;
  c.knit_substeps = scene.knit.substeps;
  return c;
}

template <typename T>
Decomposition first_partition(const Scene& scene, const HaloWidths& w, const PhaseCosts& costs,
                              int ranks, const std::array<PointSource<T>, kPhases>& points,
                              const PointShares& shares) {
  static_assert(static_cast<int>(Phase::Fluid) == 0 && static_cast<int>(Phase::Boundary) == 1 &&
                static_cast<int>(Phase::Knit) == 2);
  Vec3d lo = scene.domain.min, hi = scene.domain.max;
  for (const auto& source : points)
    if (source)
      source([&](const Vec3<T>& q) {
        for (int d = 0; d < 3; ++d) {
          (&lo.x)[d] = std::min((&lo.x)[d], double((&q.x)[d]));
          (&hi.x)[d] = std::max((&hi.x)[d], double((&q.x)[d]));
        }
      });
  if (shares.box)
    shares.box(lo, hi);
  const BlockGrid grid(lo, hi, w.block);
  std::vector<std::array<double, kPhases>> counts(grid.count(), {0, 0, 0});
  for (int p = 0; p < kPhases; ++p)
    if (points[p])
      points[p]([&](const Vec3<T>& q) { counts[grid.block_of(vec_cast<double>(q))][p] += 1; });
  if (shares.counts)
    shares.counts(counts);
  return Decomposition::partition(grid, counts, costs, ranks, w.halo_weight);
}

template <typename T>
Decomposition first_partition(const Scene& scene, const HaloWidths& w, const PhaseCosts& costs,
                              int ranks, std::span<const Vec3<T>> fluid,
                              std::span<const Vec3<T>> boundary, std::span<const Vec3<T>> knit) {
  const auto held = [](std::span<const Vec3<T>> x) -> PointSource<T> {
    return [x](const std::function<void(const Vec3<T>&)>& f) {
      for (const auto& q : x)
        f(q);
    };
  };
  return first_partition<T>(scene, w, costs, ranks, {held(fluid), held(boundary), held(knit)});
}

template <typename T>
int owner_of(const Decomposition& d, const Vec3<T>& q) {
  return d.owner(vec_cast<double>(q));
}

template <typename T>
bool owns(const Decomposition& d, int r, const Vec3<T>& q) {
  return owner_of(d, q) == r;
}

template <typename T>
std::vector<std::size_t> owned_rows(const Decomposition& d, int r, std::span<const Vec3<T>> x) {
  std::vector<std::size_t> rows;
  rows.reserve(x.size() / std::max(1, d.ranks()) + 1);
  for (std::size_t i = 0; i < x.size(); ++i)
    if (owns(d, r, x[i]))
      rows.push_back(i);
  return rows;
}

template <typename T>
GridGeometry<T> whole_grid(const Scene& scene) {
  const double h = scene.support_radius();
  const double skin = scene.solver.neighbour_list == Scene::Solver::NeighbourLists::Verlet
                          ? scene.solver.neighbour_skin * h
                          : 0.0;
  const int span = static_cast<int>(scene.solver.cell_span);
  return NeighbourGrid<T>::cover(scene.domain.min, scene.domain.max, (h + skin) / span, span);
}

template <typename T>
GridGeometry<T> rank_grid(const Decomposition& d, int r, const GridGeometry<T>& whole,
                          const HaloWidths& w) {
  const auto [lo, hi] = d.window(r, vec_cast<double>(whole.origin), double(whole.cell),
                                 {whole.nx, whole.ny, whole.nz}, w.grid_margin());
  return NeighbourGrid<T>::within(whole, lo, hi);
}

#define KF_RANK_LAYOUT(T)                                                                          \
  template Decomposition first_partition<T>(const Scene&, const HaloWidths&, const PhaseCosts&,    \
                                            int, const std::array<PointSource<T>, kPhases>&,       \
                                            const PointShares&);                                   \
  template Decomposition first_partition<T>(const Scene&, const HaloWidths&, const PhaseCosts&,    \
                                            int, std::span<const Vec3<T>>,                         \
                                            std::span<const Vec3<T>>, std::span<const Vec3<T>>);   \
  template int owner_of<T>(const Decomposition&, const Vec3<T>&);                                  \
  template bool owns<T>(const Decomposition&, int, const Vec3<T>&);                                \
  template std::vector<std::size_t> owned_rows<T>(const Decomposition&, int,                       \
                                                  std::span<const Vec3<T>>);                       \
  template GridGeometry<T> whole_grid<T>(const Scene&);                                            \
  template GridGeometry<T> rank_grid<T>(const Decomposition&, int, const GridGeometry<T>&,         \
                                        const HaloWidths&);
KF_RANK_LAYOUT(float)
KF_RANK_LAYOUT(double)
#undef KF_RANK_LAYOUT

} // namespace kf
