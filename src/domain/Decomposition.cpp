#include "domain/Decomposition.hpp"

#include "core/Error.hpp"

#include <metis.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

namespace kf {

const char* phase_name(Phase p) {
  switch (p) {
  case Phase::Fluid:
    return "fluid";
  case Phase::Boundary:
    return "boundary";
  case Phase::Knit:
    return "knit";
  }
  return "?";
}

BlockGrid::BlockGrid(const Vec3d& lo, const Vec3d& hi, double block) : lo_(lo), edge_(block) {
  if (!(block > 0))
    throw Error("decomposition: the block edge must be positive, got " + std::to_string(block));
  for (int d = 0; d < 3; ++d) {
    const double extent = (&hi.x)[d] - (&lo.x)[d];
    n_[d] = std::max(1, static_cast<int>(std::ceil(extent / block - 1e-9)));
  }
  if (double(n_[0]) * n_[1] * n_[2] > 1e8)
    throw Error("decomposition: " + std::to_string(n_[0]) + " x " + std::to_string(n_[1]) + " x " +
                std::to_string(n_[2]) + " blocks; make [parallel] block_cells larger");
}

BlockGrid BlockGrid::coarsened(int m) const {
  if (m < 1)
    throw Error("decomposition: blocks are grouped by at least 1, got " + std::to_string(m));
  BlockGrid g = *this;
  g.edge_ = edge_ * m;
  for (int d = 0; d < 3; ++d)
    g.n_[d] = (n_[d] + m - 1) / m;
  return g;
}

std::array<int, 3> BlockGrid::coords(int b) const {
  return {b % n_[0], (b / n_[0]) % n_[1], b / (n_[0] * n_[1])};
}

std::array<int, 3> BlockGrid::coords_of(const Vec3d& x) const {
  const BlockGridView g = view();
  return {g.coord(x, 0), g.coord(x, 1), g.coord(x, 2)};
}

int BlockGrid::block_of(const Vec3d& x) const {
  const auto c = coords_of(x);
  return index(c[0], c[1], c[2]);
}

double BlockGrid::distance(const Vec3d& x, int b) const {
  const auto c = coords(b);
  return std::sqrt(view().distance2(x, c.data()));
}

BlockGridView BlockGrid::view() const {
  BlockGridView g;
  g.lo = lo_;
  g.edge = edge_;
  for (int d = 0; d < 3; ++d)
    g.n[d] = n_[d];
  return g;
}

int BlockGrid::reach(double width) const {
  return std::max(1, static_cast<int>(std::ceil(width / edge_)));
}

Decomposition::Decomposition(BlockGrid grid)
    : grid_(std::move(grid)), ranks_(1), owner_(static_cast<std::size_t>(grid_.count()), 0) {}

namespace {

void metis_check(int rc, const char* what) {
  if (rc == METIS_OK)
    return;
  const char* why = rc == METIS_ERROR_INPUT    ? "bad input"
                    : rc == METIS_ERROR_MEMORY ? "out of memory"
                                               : "error";
  throw Error(std::string("decomposition: METIS ") + what + " failed (" + why + ")");
}

} // namespace

std::vector<std::array<double, kPhases>>
Decomposition::working_counts(const BlockGrid& grid,
                              const std::vector<std::array<double, kPhases>>& counts) {
  constexpr int fl = static_cast<int>(Phase::Fluid), bd = static_cast<int>(Phase::Boundary);
  std::vector<std::array<double, kPhases>> out = counts;
  bool fluid = false;
  for (const auto& c : counts)
    fluid = fluid || c[fl] > 0;
  if (!fluid)
    return out;
  for (int b = 0; b < grid.count(); ++b) {
    if (counts[b][bd] == 0)
      continue;
    const auto c = grid.coords(b);
    bool near = false;
    for (int dz = -1; dz <= 1 && !near; ++dz)
      for (int dy = -1; dy <= 1 && !near; ++dy)
        for (int dx = -1; dx <= 1 && !near; ++dx) {
          const int i = c[0] + dx, j = c[1] + dy, k = c[2] + dz;
          near = i >= 0 && j >= 0 && k >= 0 && i < grid.nx() && j < grid.ny() && k < grid.nz() &&
                 counts[grid.index(i, j, k)][fl] > 0;
        }
    if (!near)
      out[b][bd] = 0;
  }
  return out;
}

Decomposition Decomposition::partition(const BlockGrid& grid,
                                       const std::vector<std::array<double, kPhases>>& all_counts,
                                       const PhaseCosts& costs, int ranks, double ghost_width,
                                       double tolerance) {
  const int nb = grid.count();
  if (nb <= kMostGraphVertices || ranks == 1 ||
      all_counts.size() != static_cast<std::size_t>(nb)) // partition_blocks says what is wrong
    return partition_blocks(grid, all_counts, costs, ranks, ghost_width, tolerance);
  int m = 2;
  while (grid.coarsened(m).count() > kMostGraphVertices)
    ++m;
  const BlockGrid groups = grid.coarsened(m);
  std::vector<std::array<double, kPhases>> sums(std::size_t(groups.count()), {0, 0, 0});
  std::vector<int> group_of(static_cast<std::size_t>(nb));
  for (int b = 0; b < nb; ++b) {
    const auto c = grid.coords(b);
    group_of[b] = groups.index(c[0] / m, c[1] / m, c[2] / m);
    for (int p = 0; p < kPhases; ++p)
      sums[group_of[b]][p] += all_counts[b][p];
  }
  const Decomposition g = partition_blocks(groups, sums, costs, ranks, ghost_width, tolerance);
  Decomposition d(grid);
  d.ranks_ = ranks;
  for (int b = 0; b < nb; ++b)
    d.owner_[b] = g.owner_[group_of[b]];
  d.tolerance_ = g.tolerance_;
  d.landed_ = d.worst_phase_imbalance(all_counts, costs); // the blocks' walls, not the groups'
  return d;
}

Decomposition Decomposition::partition_blocks(
    const BlockGrid& grid, const std::vector<std::array<double, kPhases>>& all_counts,
    const PhaseCosts& costs, int ranks, double ghost_width, double tolerance) {
  const int nb = grid.count();
  if (static_cast<int>(all_counts.size()) != nb)
    throw Error("decomposition: " + std::to_string(all_counts.size()) + " block counts for " +
                std::to_string(nb) + " blocks");
  if (ranks < 1)
    throw Error("decomposition: at least one rank, got " + std::to_string(ranks));
  Decomposition d(grid);
  d.ranks_ = ranks;
  if (ranks == 1)
    return d;
  const auto counts = working_counts(grid, all_counts);
  if (ranks > nb)
    throw Error("decomposition: " + std::to_string(ranks) + " ranks but only " +
                std::to_string(nb) + " blocks; make [parallel] block_cells smaller");

  // Vertex weights, one per constraint: the fluid's stages (fluid and boundary particles) and,
  // when there is knit, the knit's substeps, each balanced on its own. The stages meet at the
  // halo refreshes between them, so a rank with the knit's share of one and the fluid's of the
  // other waits at each (the pour on 2 CPU ranks balanced by total cost alone: 1.01 on the whole
  // step, 30% of it waiting in refreshes). Each scaled so its total fits METIS's 32-bit sums,
  // plus one so empty blocks (where particles may go) are shared out too.
  const auto cost_of = [&](int b, int constraint) {
    if (constraint == 1)
      return counts[b][static_cast<int>(Phase::Knit)] * costs.of(Phase::Knit);
    return counts[b][static_cast<int>(Phase::Fluid)] * costs.of(Phase::Fluid) +
           counts[b][static_cast<int>(Phase::Boundary)] * costs.of(Phase::Boundary);
  };
  double knit_total = 0;
  for (int b = 0; b < nb; ++b)
    knit_total += cost_of(b, 1);
  const int constraints = knit_total > 0 ? 2 : 1;
  if (!(tolerance > 0))
    tolerance = allowance_for(constraints);
  d.tolerance_ = tolerance;
  std::vector<idx_t> vwgt(std::size_t(nb) * constraints);
  for (int c = 0; c < constraints; ++c) {
    double total = 0;
    for (int b = 0; b < nb; ++b)
      total += cost_of(b, c);
    const double scale = total > 0 ? 1e8 / total : 0.0;
    for (int b = 0; b < nb; ++b)
      vwgt[std::size_t(b) * constraints + c] =
          1 + static_cast<idx_t>(std::llround(cost_of(b, c) * scale));
  }

  // Edges to the 26 neighbours, weighted by the particles within the ghost width of the face,
  // edge or corner they share: the shared area in units of block faces times the two blocks'
  // mean density times the width.
  std::vector<idx_t> xadj(nb + 1, 0), adjncy, adjwgt;
  adjncy.reserve(std::size_t(nb) * 26);
  adjwgt.reserve(std::size_t(nb) * 26);
  const double w = std::min(ghost_width, grid.edge()) / grid.edge();
  for (int b = 0; b < nb; ++b) {
    const auto c = grid.coords(b);
    double nb_particles = 0;
    for (int p = 0; p < kPhases; ++p)
      nb_particles += all_counts[b][p];
    for (int dz = -1; dz <= 1; ++dz)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          if (!dx && !dy && !dz)
            continue;
          const int i = c[0] + dx, j = c[1] + dy, k = c[2] + dz;
          if (i < 0 || j < 0 || k < 0 || i >= grid.nx() || j >= grid.ny() || k >= grid.nz())
            continue;
          const int o = grid.index(i, j, k);
          double no = 0;
          for (int p = 0; p < kPhases; ++p)
            no += all_counts[o][p];
          const int zeros = (dx == 0) + (dy == 0) + (dz == 0); // 2: face, 1: edge, 0: corner
          const double area = zeros == 2 ? 1.0 : (zeros == 1 ? w : w * w);
          const double exchanged = 0.5 * (nb_particles + no) * w * area;
          adjncy.push_back(o);
          adjwgt.push_back(1 + static_cast<idx_t>(std::llround(std::min(exchanged, 1e6))));
        }
    xadj[b + 1] = static_cast<idx_t>(adjncy.size());
  }

  idx_t nvtxs = nb, ncon = constraints, nparts = ranks, objval = 0;
  std::vector<real_t> ubvec(constraints, static_cast<real_t>(tolerance));
  const auto run = [&](bool contiguous) {
    idx_t options[METIS_NOPTIONS];
    metis_check(METIS_SetDefaultOptions(options), "SetDefaultOptions");
    options[METIS_OPTION_CONTIG] = contiguous ? 1 : 0;
    options[METIS_OPTION_SEED] = 1; // every rank computes the same partition
    options[METIS_OPTION_NUMBERING] = 0;
    std::vector<idx_t> part(nb, 0);
    metis_check(METIS_PartGraphKway(&nvtxs, &ncon, xadj.data(), adjncy.data(), vwgt.data(), nullptr,
                                    adjwgt.data(), &nparts, nullptr, ubvec.data(), options, &objval,
                                    part.data()),
                "PartGraphKway");
    return part;
  };
  // The worst constraint's heaviest part over its mean.
  const auto worst = [&](const std::vector<idx_t>& part) {
    double w = 1;
    for (int c = 0; c < constraints; ++c) {
      std::vector<double> per(ranks, 0.0);
      for (int b = 0; b < nb; ++b)
        per[part[b]] += double(vwgt[std::size_t(b) * constraints + c]);
      w = std::max(w, imbalance(per));
    }
    return w;
  };
  // One connected region a rank (fewer neighbours, less halo) where METIS keeps the balance so;
  // with two constraints contiguity may cost it (the phases apart in space: 1.35 on 2 ranks), and
  // then the regions may come in pieces.
  std::vector<idx_t> part = run(true);
  if (constraints > 1 && worst(part) > tolerance + 0.02) {
    std::vector<idx_t> pieces = run(false);
    if (worst(pieces) < worst(part))
      part = std::move(pieces);
  }
  for (int b = 0; b < nb; ++b)
    d.owner_[b] = static_cast<int>(part[b]);
  d.landed_ = d.worst_phase_imbalance(all_counts, costs);
  return d;
}

void Decomposition::ghost_ranks(const Vec3d& x, double width, std::vector<int>& out) const {
  out.clear();
  if (ranks_ == 1)
    return;
  for_each_ghost_rank(grid_.view(), owner_.data(), x, width, grid_.reach(width), [&](int o) {
    if (std::find(out.begin(), out.end(), o) == out.end())
      out.push_back(o);
  });
  std::sort(out.begin(), out.end());
}

std::array<std::array<int, 3>, 2> Decomposition::block_span(int r) const {
  std::array<int, 3> blo{grid_.nx(), grid_.ny(), grid_.nz()}, bhi{-1, -1, -1};
  for (int b = 0; b < grid_.count(); ++b)
    if (owner_[b] == r) {
      const auto c = grid_.coords(b);
      for (int a = 0; a < 3; ++a) {
        blo[a] = std::min(blo[a], c[a]);
        bhi[a] = std::max(bhi[a], c[a]);
      }
    }
  return {blo, bhi};
}

std::array<std::array<int, 3>, 2> Decomposition::window(int r, const Vec3d& origin, double cell,
                                                        const std::array<int, 3>& n,
                                                        double margin) const {
  const auto [blo, bhi] = block_span(r);
  std::array<int, 3> lo{0, 0, 0}, hi{n[0] - 1, n[1] - 1, n[2] - 1};
  if (bhi[0] < 0)
    return {lo, hi};
  const double o[3] = {origin.x, origin.y, origin.z};
  const double bo[3] = {grid_.origin().x, grid_.origin().y, grid_.origin().z};
  for (int a = 0; a < 3; ++a) {
    if (blo[a] > 0)
      lo[a] = std::clamp(
          int(std::floor((bo[a] + blo[a] * grid_.edge() - margin - o[a]) / cell)) - 1, 0, n[a] - 1);
    if (bhi[a] < grid_.dim(a) - 1)
      hi[a] = std::clamp(
          int(std::floor((bo[a] + (bhi[a] + 1) * grid_.edge() + margin - o[a]) / cell)) + 1, lo[a],
          n[a] - 1);
  }
  return {lo, hi};
}

std::array<Vec3d, 2> Decomposition::region_box(int r) const {
  constexpr double inf = std::numeric_limits<double>::infinity();
  const auto [blo, bhi] = block_span(r);
  if (bhi[0] < 0)
    return {Vec3d{inf, inf, inf}, Vec3d{-inf, -inf, -inf}};
  const double o[3] = {grid_.origin().x, grid_.origin().y, grid_.origin().z};
  double lo[3], hi[3];
  for (int a = 0; a < 3; ++a) {
    lo[a] = blo[a] == 0 ? -inf : o[a] + blo[a] * grid_.edge();
    hi[a] = bhi[a] == grid_.dim(a) - 1 ? inf : o[a] + (bhi[a] + 1) * grid_.edge();
  }
  return {Vec3d{lo[0], lo[1], lo[2]}, Vec3d{hi[0], hi[1], hi[2]}};
}

double Decomposition::distance_to_region(const Vec3d& x, int r) const {
  double best = 1e300;
  for (int b = 0; b < grid_.count(); ++b)
    if (owner_[b] == r)
      best = std::min(best, grid_.distance(x, b));
  return best;
}

std::vector<double>
Decomposition::rank_costs(const std::vector<std::array<double, kPhases>>& all_counts,
                          const PhaseCosts& costs) const {
  const auto counts = working_counts(grid_, all_counts);
  std::vector<double> per(ranks_, 0.0);
  for (int b = 0; b < grid_.count(); ++b)
    for (int p = 0; p < kPhases; ++p)
      per[owner_[b]] += counts[b][p] * costs.of(static_cast<Phase>(p));
  return per;
}

double
Decomposition::worst_phase_imbalance(const std::vector<std::array<double, kPhases>>& all_counts,
                                     const PhaseCosts& costs) const {
  // partition_blocks' two constraints, per rank: the fluid's stages and the knit's substeps.
  const auto counts = working_counts(grid_, all_counts);
  std::vector<double> stages(ranks_, 0.0), knit(ranks_, 0.0);
  for (int b = 0; b < grid_.count(); ++b) {
    const auto& c = counts[b];
    stages[owner_[b]] += c[static_cast<int>(Phase::Fluid)] * costs.of(Phase::Fluid) +
                         c[static_cast<int>(Phase::Boundary)] * costs.of(Phase::Boundary);
    knit[owner_[b]] += c[static_cast<int>(Phase::Knit)] * costs.of(Phase::Knit);
  }
  const bool has_knit = std::accumulate(knit.begin(), knit.end(), 0.0) > 0;
  return std::max(imbalance(stages), has_knit ? imbalance(knit) : 1.0);
}

bool Decomposition::repartition_pays(double most, double mean, std::uint64_t intervals_held,
                                     double last_cost) {
  return !(last_cost > 0) || (most - mean) * static_cast<double>(intervals_held) >= last_cost;
}

bool Decomposition::repartition_promises(double counted, double tolerance, double landed) {
  return counted > std::max(1.0 + 2.0 * (tolerance - 1.0), landed + (tolerance - 1.0));
}

double Decomposition::imbalance(const std::vector<double>& per_rank) {
  if (per_rank.empty())
    return 1.0;
  const double mean =
      std::accumulate(per_rank.begin(), per_rank.end(), 0.0) / double(per_rank.size());
  const double most = *std::max_element(per_rank.begin(), per_rank.end());
  return mean > 0 ? most / mean : 1.0;
}

} // namespace kf
