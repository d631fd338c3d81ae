#include "kernels/grid/NeighbourGrid.hpp"

#include "core/Error.hpp"
#include "kernels/exec/PeakByLabel.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <vector>

namespace kf {

namespace {

// Spreads the low 32 bits of v so that one zero bit separates each.
std::uint64_t spread2(std::uint64_t v) {
  v &= 0xFFFFFFFFULL;
  v = (v | v << 16) & 0x0000FFFF0000FFFFULL;
  v = (v | v << 8) & 0x00FF00FF00FF00FFULL;
  v = (v | v << 4) & 0x0F0F0F0F0F0F0F0FULL;
  v = (v | v << 2) & 0x3333333333333333ULL;
  v = (v | v << 1) & 0x5555555555555555ULL;
  return v;
}

// Empties the cells the last build filled (its keys; the outside rank is in no cell).
struct ClearCells {
  const std::uint32_t* keys;
  std::uint32_t* start;
  std::uint32_t* end;
  int sub;
  std::uint32_t outside;
  KF_HD KF_INLINE void operator()(std::size_t i) const {
    const std::uint32_t k = keys[i] >> sub;
    if (k != outside)
      start[k] = end[k] = 0u;
  }
};

// Point i's sort key: its cell's rank, then its sub-cell code; the outside rank when it lies
// outside the keep box (keeping).
template <typename T>
struct CellKeys {
  const Vec3<T>* x;
  GridGeometry<T> geo;
  const std::uint32_t* rank;
  std::uint32_t* keys;
  std::uint32_t* perm;
  int levels;
  std::uint32_t outside;
  bool keeping;
  KeepBox<T> keep;
  KF_HD KF_INLINE void operator()(std::size_t i) const {
    const Vec3<T> q = x[i];
    const int sub = 3 * levels;
    int cx, cy, cz;
    geo.coords(q, cx, cy, cz);
    keys[i] = keeping && keep.dropped(i, q)
                  ? outside << sub
                  : rank[geo.linear(cx, cy, cz)] << sub | geo.sub_cell_code(q, cx, cy, cz, levels);
    perm[i] = static_cast<std::uint32_t>(i);
  }
};

// Each cell's range in the sorted keys. The points outside (sorted last) are in no cell; the
// first of them, or the end when there are none, gives the count kept (one thread writes it).
struct CellRanges {
  const std::uint32_t* keys;
  std::uint32_t* start;
  std::uint32_t* end;
  std::uint32_t* kept;
  std::size_t n;
  int sub;
  std::uint32_t outside;
  KF_HD KF_INLINE void operator()(std::size_t i) const {
    const std::uint32_t k = keys[i] >> sub;
    if (k == outside) {
      if (i == 0 || keys[i - 1] >> sub != outside)
        *kept = static_cast<std::uint32_t>(i);
      return;
    }
    if (i == 0 || keys[i - 1] >> sub != k)
      start[k] = static_cast<std::uint32_t>(i);
    if (i + 1 == n || keys[i + 1] >> sub != k)
      end[k] = static_cast<std::uint32_t>(i + 1);
    if (i + 1 == n)
      *kept = static_cast<std::uint32_t>(n);
  }
};

// Orders each run of equal keys (points sharing a sub-cell) by id: the thread at a run's start
// insertion-sorts its slots (runs are a few points; a whole cell without sub-cell order). The
// points outside a keep box stay in their order.
struct TiesById {
  const std::uint32_t* keys;
  std::uint32_t* perm;
  const std::uint64_t* id;
  std::size_t n;
  int sub;
  std::uint32_t outside;
  KF_HD KF_INLINE void operator()(std::size_t i) const {
    const std::uint32_t k = keys[i];
    if (i + 1 == n || keys[i + 1] != k || (i > 0 && keys[i - 1] == k) || k >> sub == outside)
      return;
    std::size_t end = i + 2;
    while (end < n && keys[end] == k)
      ++end;
    for (std::size_t a = i + 1; a < end; ++a) {
      const std::uint32_t p = perm[a];
      const std::uint64_t q = id[p];
      std::size_t b = a;
      for (; b > i && id[perm[b - 1]] > q; --b)
        perm[b] = perm[b - 1];
      perm[b] = p;
    }
  }
};

} // namespace

template <typename T>
GridGeometry<T> NeighbourGrid<T>::cover(const Vec3d& lo, const Vec3d& hi, double cell, int pad) {
  if (!(cell > 0))
    throw Error("neighbour grid: cell size must be > 0");
  if (pad < 1)
    throw Error("neighbour grid: padding must be at least one cell");
  GridGeometry<T> g;
  g.cell = static_cast<T>(cell);
  g.inv_cell = static_cast<T>(1.0 / cell);
  const double margin = pad * cell;
  g.origin = vec_cast<T>(Vec3d{lo.x - margin, lo.y - margin, lo.z - margin});
  auto count = [&](double a, double b) {
    return static_cast<int>(std::ceil((b - a) / cell)) + 2 * pad;
  };
  g.nx = count(lo.x, hi.x);
  g.ny = count(lo.y, hi.y);
  g.nz = count(lo.z, hi.z);
  const double total = double(g.nx) * g.ny * g.nz;
  if (total > 2.0e9)
    throw Error("neighbour grid of " + std::to_string(g.nx) + " x " + std::to_string(g.ny) + " x " +
                std::to_string(g.nz) +
                " cells is too large: enlarge the cell or shrink the domain");
  return g;
}

template <typename T>
GridGeometry<T> NeighbourGrid<T>::within(const GridGeometry<T>& whole, std::array<int, 3> lo,
                                         std::array<int, 3> hi) {
  GridGeometry<T> g = whole;
  const int n[3] = {whole.nx, whole.ny, whole.nz};
  const int o[3] = {whole.ox, whole.oy, whole.oz};
  int first[3], count[3];
  for (int a = 0; a < 3; ++a) {
    first[a] = std::clamp(lo[a], o[a], o[a] + n[a] - 1);
    count[a] = std::clamp(hi[a], first[a], o[a] + n[a] - 1) - first[a] + 1;
  }
  g.ox = first[0];
  g.oy = first[1];
  g.oz = first[2];
  g.nx = count[0];
  g.ny = count[1];
  g.nz = count[2];
  return g;
}

template <typename T>
NeighbourGrid<T>::NeighbourGrid(exec::Backend b, const GridGeometry<T>& geo, int span,
                                int order_levels, const char* name)
    : geo_(geo), span_(span), rank_(b, 0, exec::joined_label(name, "rank")),
      start_(b, 0, exec::joined_label(name, "start")), end_(b, 0, exec::joined_label(name, "end")),
      keys_(b, 0, exec::joined_label(name, "keys")),
      perm_(b, 0, exec::joined_label(name, "permutation")),
      kept_(b, 1, exec::joined_label(name, "kept")) {
  if (span < 1)
    throw Error("neighbour grid: span must be at least one cell");
  if (order_levels < 0 || order_levels > kMaxOrderLevels)
    throw Error("neighbour grid: order levels must be 0 to " + std::to_string(kMaxOrderLevels));
  const std::uint32_t n = geo.cells();
  // Rank of each cell, computed once: rows of cells along x in Morton order of (y, z), and x
  // running within a row. Sorting particles by rank groups each cell's particles and keeps
  // nearby cells nearby in memory; cells next to each other along x are next to each other in
  // rank, so a neighbour loop reads each row of its cells as one range. Only the rows are
  // sorted (ny nz of them), so a large grid costs O(cells) to set up. A window of a whole grid
  // (within) orders its rows by their codes on the whole grid: any two particles then go in the
  // order the whole grid gives them (passes that sum over particles in their order, as a
  // transposed list does, sum as on one rank).
  const std::uint32_t rows =
      static_cast<std::uint32_t>(geo.ny) * static_cast<std::uint32_t>(geo.nz);
  std::vector<std::uint32_t> order(rows);
  std::iota(order.begin(), order.end(), 0u);
  std::vector<std::uint64_t> code(rows);
  for (int z = 0; z < geo.nz; ++z)
    for (int y = 0; y < geo.ny; ++y)
      code[std::uint32_t(z) * std::uint32_t(geo.ny) + std::uint32_t(y)] =
          spread2(std::uint64_t(y + geo.oy)) | spread2(std::uint64_t(z + geo.oz)) << 1;
  std::sort(order.begin(), order.end(),
            [&](std::uint32_t a, std::uint32_t b) { return code[a] < code[b]; });
  std::vector<std::uint32_t> rank(n);
  const std::uint32_t nx = static_cast<std::uint32_t>(geo.nx);
  for (std::uint32_t r = 0; r < rows; ++r) // order[r] = z ny + y, and linear = (z ny + y) nx + x
    for (std::uint32_t x = 0; x < nx; ++x)
      rank[order[r] * nx + x] = r * nx + x;
  rank_.assign(rank);
  start_.resize(n);
  end_.resize(n);
  levels_ = usable_order_levels(n + 1, order_levels); // rank n: outside a KeepBox
  key_bits_ = rank_bits(n + 1) + 3 * levels_;
}

template <typename T>
int NeighbourGrid<T>::rank_bits(std::uint32_t cells) {
  int bits = 1;
  while (bits < 32 && (std::uint64_t(1) << bits) < cells)
    ++bits;
  return bits;
}

template <typename T>
int NeighbourGrid<T>::usable_order_levels(std::uint32_t cells, int order_levels) {
  int levels = order_levels;
  while (levels > 0 && rank_bits(cells) + 3 * levels > 32)
    --levels;
  return levels;
}

template <typename T>
void NeighbourGrid<T>::build(const exec::Exec& ex, const Vec3<T>* x, std::size_t n,
                             const std::uint64_t* tie_id) {
  sort(ex, x, n, nullptr, tie_id);
}

template <typename T>
void NeighbourGrid<T>::build_keeping(const exec::Exec& ex, const Vec3<T>* x, std::size_t n,
                                     const KeepBox<T>& keep, const std::uint64_t* tie_id) {
  sort(ex, x, n, &keep, tie_id);
  if (n == 0)
    exec::fill(ex, kept_, 0u, "grid.kept");
  if (!kept_read_)
    kept_read_.emplace(kept_.backend(), 1, "grid.kept");
  kept_read_->start(kept_.data());
}

template <typename T>
std::size_t NeighbourGrid<T>::kept() {
  if (kept_read_ && kept_read_->pending())
    kept_count_ = kept_read_->wait()[0];
  return kept_count_;
}

template <typename T>
void NeighbourGrid<T>::drop_outside(std::size_t kept) {
  if (kept > perm_.size())
    throw Error("neighbour grid: drop_outside(" + std::to_string(kept) + ") of " +
                std::to_string(perm_.size()) + " sorted points");
  keys_.resize(kept);
  perm_.resize(kept);
}

template <typename T>
void NeighbourGrid<T>::sort(const exec::Exec& ex, const Vec3<T>* x, std::size_t n,
                            const KeepBox<T>* keep, const std::uint64_t* tie_id) {
  // Empty cells must read start = end = 0. Clearing the whole table costs O(cells) per build,
  // which dominates when the particles occupy few cells (a cloth in a room); after the first
  // build only the cells the previous build filled (its keys) are cleared.
  // A key is the cell's rank shifted past `sub` bits of sub-cell code (order_levels).
  const int sub = 3 * levels_;
  const std::uint32_t outside = geo_.cells(); // the rank after the last cell's
  if (!cleared_) {
    exec::fill(ex, start_, 0u, "grid.clear");
    exec::fill(ex, end_, 0u, "grid.clear");
    cleared_ = true;
  } else if (keys_.size() > 0) {
    exec::for_each(ex, keys_.size(),
                   ClearCells{keys_.data(), start_.data(), end_.data(), sub, outside},
                   "grid.clear");
  }
  keys_.resize(n);
  perm_.resize(n);
  exec::for_each(ex, n,
                 CellKeys<T>{x, geo_, rank_.data(), keys_.data(), perm_.data(), levels_, outside,
                             keep != nullptr, keep ? *keep : KeepBox<T>{}},
                 "grid.keys");
  exec::sort_by_key(ex, keys_, perm_, key_bits_, "grid.sort");
  if (tie_id && n > 1)
    exec::for_each(ex, n, TiesById{keys_.data(), perm_.data(), tie_id, n, sub, outside},
                   "grid.ties");
  exec::for_each(
      ex, n, CellRanges{keys_.data(), start_.data(), end_.data(), kept_.data(), n, sub, outside},
      "grid.ranges");
}

namespace {

template <typename T>
struct OccupiedAround {
  CellView<T> cells;
  std::uint8_t* flag;
  KF_HD void operator()(std::size_t c) const {
    const GridGeometry<T>& g = cells.geo;
    const int nx = g.nx, ny = g.ny;
    const int x = static_cast<int>(c % std::size_t(nx));
    const int y = static_cast<int>((c / std::size_t(nx)) % std::size_t(ny));
    const int z = static_cast<int>(c / (std::size_t(nx) * std::size_t(ny)));
    // The centre of the cell: for_each_candidate from any point of it visits the same cells.
    flag[c] = cells.has_candidates(g.centre(x, y, z)) ? 1 : 0;
  }
};

} // namespace

template <typename T>
void NeighbourGrid<T>::occupied_around(const exec::Exec& ex,
                                       exec::DeviceBuffer<std::uint8_t>& flag) const {
  flag.resize(geo_.cells());
  exec::for_each(ex, geo_.cells(), OccupiedAround<T>{view(), flag.data()}, "grid.occupied");
}

template <typename T>
std::size_t NeighbourGrid<T>::bytes() const {
  return rank_.capacity_bytes() + start_.capacity_bytes() + end_.capacity_bytes() +
         keys_.capacity_bytes() + perm_.capacity_bytes();
}

template class NeighbourGrid<float>;
template class NeighbourGrid<double>;

} // namespace kf
