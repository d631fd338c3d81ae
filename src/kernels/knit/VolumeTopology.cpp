#include "kernels/knit/VolumeTopology.hpp"

#include "core/Error.hpp"
#include "kernels/knit/LocalRows_K.hpp"
#include "kernels/knit/PointRows.hpp"

#include <algorithm>
#include <numeric>
#include <string>

namespace kf {

template <typename T>
VolumeTopology<T>::VolumeTopology(exec::Backend b)
    : count_(b, 0, "knit.volume.count"), cell_(b, 0, "knit.volume.cell"),
      point_(b, 0, "knit.volume.point"), rest_(b, 0, "knit.volume.rest"), k_(b, 0, "knit.volume.k"),
      slot_(b, 0, "knit.volume.slot") {}

namespace {

// The cells' corners and constants. Rejects a corner >= n and repeated corners.
template <typename T>
void cell_table(const std::vector<VolumeCell>& cells, std::size_t n_points,
                std::vector<std::uint32_t>& point, std::vector<T>& rest, std::vector<T>& k) {
  point.clear();
  rest.clear();
  k.clear();
  for (const VolumeCell& c : cells) {
    for (int r = 0; r < 4; ++r) {
      if (c.point[r] >= n_points)
        throw Error("volume cell point " + std::to_string(c.point[r]) + " is not one of " +
                    std::to_string(n_points));
      for (int q = 0; q < r; ++q)
        if (c.point[q] == c.point[r])
          throw Error("volume cell with a repeated point " + std::to_string(c.point[r]));
      point.push_back(c.point[r]);
    }
    rest.push_back(static_cast<T>(c.rest_volume));
    k.push_back(static_cast<T>(c.k));
  }
}

// Each row's cells where `layout(rows, width)` puts them (in the list's order): row_of[p] is
// point p's row or kAbsentPoint, index[c] the number cell c goes by. Returns the width (at least
// `width`). `table(size)` gives the storage (zeroed), written in place (as SpringTopology's).
template <typename Layout, typename Table>
std::uint32_t
cell_rows(const std::vector<VolumeCell>& cells, const std::vector<std::uint32_t>& index,
          const std::vector<std::uint32_t>& row_of, std::size_t n_rows, std::uint32_t width,
          Layout layout, Table table, std::vector<std::uint32_t>& count) {
  count.assign(n_rows, 0);
  for (const VolumeCell& c : cells)
    for (const std::uint32_t p : c.point)
      if (p >= row_of.size())
        throw Error("volume cell point " + std::to_string(p) + " is not one of " +
                    std::to_string(row_of.size()));
      else if (row_of[p] != kAbsentPoint)
        ++count[row_of[p]];
  for (std::uint32_t c : count)
    width = std::max(width, c);
  const RowLayout rows = layout(n_rows, width);
  std::uint32_t* cell = table(std::size_t(width) * n_rows);
  std::vector<std::uint32_t> fill(n_rows, 0);
  for (std::size_t c = 0; c < cells.size(); ++c)
    for (const std::uint32_t p : cells[c].point)
      if (const std::uint32_t r = row_of[p]; r != kAbsentPoint)
        cell[rows.at(fill[r]++, r)] = index[c];
  return width;
}

// Marks the cells the owned points' rows name (each mesh cell's slot set to 1). Several points
// may mark one cell at once: the same word written with the same value.
struct MarkUsedCells {
  const std::uint32_t* count;
  const std::uint32_t* cell;
  RowLayout rows;
  std::uint32_t* used;
  KF_HD KF_INLINE void operator()(std::size_t k) const {
    for (std::uint32_t e = 0; e < count[k]; ++e)
      used[cell[rows.at(e, k)]] = 1;
  }
};

// A used mesh cell (after the exclusive scan of the marks: slot[c + 1] > slot[c], `used` past
// the last) copied to its compact slot, its corners by local index.
template <typename T>
struct CompactCell {
  const std::uint32_t* mesh_point;
  const T* mesh_rest;
  const T* mesh_k;
  const std::uint32_t* slot;
  std::size_t n;
  std::uint32_t used;
  LocalOfId local;
  std::uint32_t* point;
  T* rest;
  T* k;
  KF_HD KF_INLINE void operator()(std::size_t c) const {
    const std::uint32_t s = slot[c], next = c + 1 < n ? slot[c + 1] : used;
    if (next == s)
      return;
    for (int r = 0; r < 4; ++r)
      point[4 * std::size_t(s) + r] = local(mesh_point[4 * c + r]);
    rest[s] = mesh_rest[c];
    k[s] = mesh_k[c];
  }
};

// The owned points' rows from mesh cell indices to compact slots.
struct CellToSlot {
  const std::uint32_t* count;
  std::uint32_t* cell;
  RowLayout rows;
  const std::uint32_t* slot;
  KF_HD KF_INLINE void operator()(std::size_t k) const {
    for (std::uint32_t e = 0; e < count[k]; ++e) {
      std::uint32_t& c = cell[rows.at(e, k)];
      c = slot[c];
    }
  }
};

} // namespace

template <typename T>
void VolumeTopology<T>::build(const std::vector<VolumeCell>& cells, std::size_t n_points) {
  std::vector<std::uint32_t> count, cell, point, index(cells.size()), row_of(n_points);
  std::vector<T> rest, k;
  std::iota(index.begin(), index.end(), 0u);
  std::iota(row_of.begin(), row_of.end(), 0u);
  const exec::Backend b = count_.backend();
  cell_table(cells, n_points, point, rest, k);
  width_ = cell_rows(
      cells, index, row_of, n_points, 0,
      [b](std::size_t n, std::uint32_t w) { return RowLayout::for_backend(b, n, w); },
      [&cell](std::size_t size) {
        cell.assign(size, 0);
        return cell.data();
      },
      count);
  count_.assign(count);
  cell_.assign(cell);
  point_.assign(point);
  rest_.assign(rest);
  k_.assign(k);
  cells_ = cells.size();
}

template <typename T>
typename VolumeTopology<T>::Cells
VolumeTopology<T>::mesh_cells(exec::Backend b, const std::vector<VolumeCell>& cells,
                              std::size_t n_points) {
  std::vector<std::uint32_t> point;
  std::vector<T> rest, k;
  cell_table(cells, n_points, point, rest, k);
  Cells m;
  m.point = exec::HostReadable<std::uint32_t>(b, point, "knit.mesh.volume.point");
  m.rest = exec::HostReadable<T>(b, rest, "knit.mesh.volume.rest");
  m.k = exec::HostReadable<T>(b, k, "knit.mesh.volume.k");
  m.cells = cells.size();
  return m;
}

template <typename T>
typename VolumeTopology<T>::HostRows
VolumeTopology<T>::host_rows(exec::Backend b, const std::vector<VolumeCell>& cells,
                             const std::vector<std::uint32_t>& index, std::size_t n_points,
                             const std::vector<std::uint64_t>& ids, std::uint32_t width) {
  if (index.size() != cells.size())
    throw Error("volume cell rows: " + std::to_string(index.size()) + " indices for " +
                std::to_string(cells.size()) + " cells");
  std::vector<std::uint32_t> count;
  const std::vector<std::uint32_t> row_of = rows_of_points(ids, n_points, "volume cell rows");
  HostRows m;
  m.width = cell_rows(
      cells, index, row_of, ids.size(), width,
      [](std::size_t, std::uint32_t w) {
        return RowLayout{1, w};
      },
      [&m, b](std::size_t size) {
        m.cell = exec::HostReadable<std::uint32_t>(b, size, "knit.rank.volume.cell");
        return m.cell.data();
      },
      count);
  m.count = exec::HostReadable<std::uint32_t>(b, count, "knit.rank.volume.count");
  return m;
}

template <typename T>
void VolumeTopology<T>::localize(const exec::Exec& ex, const Cells& cells, const HostRows& from,
                                 const std::uint32_t* local_of_id, std::size_t owned) {
  if (from.points() < owned)
    throw Error("knit volume cells: rows for " + std::to_string(from.points()) + " points, " +
                std::to_string(owned) + " owned");
  cells_ = cells.cells;
  width_ = from.width;
  // Every column here is written anew (a row's slots past its count never): each grows
  // without copying.
  count_.resize_snug_discarding(owned);
  cell_.resize_snug_discarding(std::size_t(width_) * owned);
  exec::for_each(ex, owned,
                 LocalRowGather<std::uint32_t, SameEntry>{from.count.data(),
                                                          from.cell.data(),
                                                          from.rows(),
                                                          rows(),
                                                          count_.data(),
                                                          cell_.data(),
                                                          {}},
                 "knit.volumes.localize");
  // Only the cells the owned points' rows name, compacted (a mark a mesh cell, scanned into
  // slots): a rank's backend holds its share of the cells' corners and constants, not the
  // whole mesh's; each row keeps its order, so the forces sum as before.
  slot_.resize_snug_discarding(cells.cells);
  exec::fill(ex, slot_, std::uint32_t(0), "knit.volumes.localize");
  exec::for_each(ex, owned, MarkUsedCells{count_.data(), cell_.data(), rows(), slot_.data()},
                 "knit.volumes.localize");
  const auto used = static_cast<std::uint32_t>(
      cells.cells ? exec::exclusive_scan(ex, slot_, slot_, "knit.volumes.localize") : 0);
  point_.resize_snug_discarding(4 * std::size_t(used));
  rest_.resize_snug_discarding(used);
  k_.resize_snug_discarding(used);
  exec::for_each(ex, cells.cells,
                 CompactCell<T>{cells.point.data(),
                                cells.rest.data(),
                                cells.k.data(),
                                slot_.data(),
                                cells.cells,
                                used,
                                {local_of_id},
                                point_.data(),
                                rest_.data(),
                                k_.data()},
                 "knit.volumes.localize");
  exec::for_each(ex, owned, CellToSlot{count_.data(), cell_.data(), rows(), slot_.data()},
                 "knit.volumes.localize");
}

template <typename T>
VolumeView<T> VolumeTopology<T>::view() const {
  if (cells_ == 0)
    return {};
  return {count_.data(), cell_.data(), point_.data(), rest_.data(), k_.data(), rows()};
}

template <typename T>
std::size_t VolumeTopology<T>::bytes() const {
  return count_.capacity_bytes() + cell_.capacity_bytes() + point_.capacity_bytes() +
         rest_.capacity_bytes() + k_.capacity_bytes() + slot_.capacity_bytes();
}

template class VolumeTopology<float>;
template class VolumeTopology<double>;

} // namespace kf
