#include "kernels/grid/NeighbourGrid.hpp"

#include "core/Error.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <vector>

namespace kf {

namespace {

// Spreads the low 21 bits of v so that two zero bits separate each.
std::uint64_t spread3(std::uint64_t v) {
  v &= 0x1FFFFF;
  v = (v | v << 32) & 0x1F00000000FFFFULL;
  v = (v | v << 16) & 0x1F0000FF0000FFULL;
  v = (v | v << 8) & 0x100F00F00F00F00FULL;
  v = (v | v << 4) & 0x10C30C30C30C30C3ULL;
  v = (v | v << 2) & 0x1249249249249249ULL;
  return v;
}

std::uint64_t morton(int x, int y, int z) {
  return spread3(static_cast<std::uint64_t>(x)) | spread3(static_cast<std::uint64_t>(y)) << 1 |
         spread3(static_cast<std::uint64_t>(z)) << 2;
}

} // namespace

template <typename T>
GridGeometry<T> NeighbourGrid<T>::cover(const Vec3d& lo, const Vec3d& hi, double cell) {
  if (!(cell > 0))
    throw Error("neighbour grid: cell size must be > 0");
  GridGeometry<T> g;
  g.cell = static_cast<T>(cell);
  g.inv_cell = static_cast<T>(1.0 / cell);
  g.origin = vec_cast<T>(Vec3d{lo.x - cell, lo.y - cell, lo.z - cell});
  auto count = [&](double a, double b) { return static_cast<int>(std::ceil((b - a) / cell)) + 2; };
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
NeighbourGrid<T>::NeighbourGrid(exec::Backend b, const GridGeometry<T>& geo)
    : geo_(geo), rank_(b, 0, "grid.rank"), start_(b, 0, "grid.start"), end_(b, 0, "grid.end"),
      keys_(b, 0, "grid.keys"), perm_(b, 0, "grid.permutation") {
  const std::uint32_t n = geo.cells();
  // Rank of each cell in Morton order, computed once: sorting particles by rank groups each
  // cell's particles and keeps nearby cells nearby in memory.
  std::vector<std::uint32_t> order(n);
  std::iota(order.begin(), order.end(), 0u);
  std::vector<std::uint64_t> code(n);
  for (int z = 0; z < geo.nz; ++z)
    for (int y = 0; y < geo.ny; ++y)
      for (int x = 0; x < geo.nx; ++x)
        code[geo.linear(x, y, z)] = morton(x, y, z);
  std::sort(order.begin(), order.end(),
            [&](std::uint32_t a, std::uint32_t b) { return code[a] < code[b]; });
  std::vector<std::uint32_t> rank(n);
  for (std::uint32_t r = 0; r < n; ++r)
    rank[order[r]] = r;
  rank_.assign(rank);
  start_.resize(n);
  end_.resize(n);
  while (key_bits_ < 32 && (std::uint64_t(1) << key_bits_) < n)
    ++key_bits_;
}

template <typename T>
void NeighbourGrid<T>::build(const exec::Exec& ex, const Vec3<T>* x, std::size_t n) {
  // Empty cells must read start = end = 0. Clearing the whole table costs O(cells) per build,
  // which dominates when the particles occupy few cells (a cloth in a room); after the first
  // build only the cells the previous build filled (its keys) are cleared.
  if (!cleared_) {
    exec::fill(ex, start_, 0u, "grid.clear");
    exec::fill(ex, end_, 0u, "grid.clear");
    cleared_ = true;
  } else if (keys_.size() > 0) {
    const std::uint32_t* old = keys_.data();
    std::uint32_t* st = start_.data();
    std::uint32_t* en = end_.data();
    exec::for_each(
        ex, keys_.size(), [=] KF_HD(std::size_t i) { st[old[i]] = en[old[i]] = 0u; }, "grid.clear");
  }
  keys_.resize(n);
  perm_.resize(n);
  const GridGeometry<T> geo = geo_;
  const std::uint32_t* rank = rank_.data();
  std::uint32_t* keys = keys_.data();
  std::uint32_t* perm = perm_.data();
  exec::for_each(
      ex, n,
      [=] KF_HD(std::size_t i) {
        int cx, cy, cz;
        geo.coords(x[i], cx, cy, cz);
        keys[i] = rank[geo.linear(cx, cy, cz)];
        perm[i] = static_cast<std::uint32_t>(i);
      },
      "grid.keys");
  exec::sort_by_key(ex, keys_, perm_, key_bits_, "grid.sort");
  std::uint32_t* start = start_.data();
  std::uint32_t* end = end_.data();
  exec::for_each(
      ex, n,
      [=] KF_HD(std::size_t i) {
        const std::uint32_t k = keys[i];
        if (i == 0 || keys[i - 1] != k)
          start[k] = static_cast<std::uint32_t>(i);
        if (i + 1 == n || keys[i + 1] != k)
          end[k] = static_cast<std::uint32_t>(i + 1);
      },
      "grid.ranges");
}

template <typename T>
std::size_t NeighbourGrid<T>::bytes() const {
  return rank_.capacity_bytes() + start_.capacity_bytes() + end_.capacity_bytes() +
         keys_.capacity_bytes() + perm_.capacity_bytes();
}

template class NeighbourGrid<float>;
template class NeighbourGrid<double>;

} // namespace kf
