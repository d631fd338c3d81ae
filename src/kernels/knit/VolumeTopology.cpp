#include "kernels/knit/VolumeTopology.hpp"

#include "core/Error.hpp"
#include "kernels/knit/LocalRows_K.hpp"

#include <algorithm>
#include <string>

namespace kf {

template <typename T>
VolumeTopology<T>::VolumeTopology(exec::Backend b)
    : count_(b, 0, "knit.volume.count"), cell_(b, 0, "knit.volume.cell"),
      point_(b, 0, "knit.volume.point"), rest_(b, 0, "knit.volume.rest"),
      k_(b, 0, "knit.volume.k") {}

namespace {

// The cells' tables: each point's count and its cells where `layout(n, width)` puts them (in the
// list's order), each cell's corners and constants. Rejects a corner >= n and repeated corners.
// `table(size)` gives the point -> cells table's storage (zeroed), written in place (as
// SpringTopology's rows).
template <typename T, typename Layout, typename Table>
std::uint32_t cell_rows(const std::vector<VolumeCell>& cells, std::size_t n_points, Layout layout,
                        Table table, std::vector<std::uint32_t>& count,
                        std::vector<std::uint32_t>& point, std::vector<T>& rest,
                        std::vector<T>& k) {
  count.assign(n_points, 0);
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
      ++count[c.point[r]];
      point.push_back(c.point[r]);
    }
    rest.push_back(static_cast<T>(c.rest_volume));
    k.push_back(static_cast<T>(c.k));
  }
  std::uint32_t width = 0;
  for (std::uint32_t c : count)
    width = std::max(width, c);
  const RowLayout rows = layout(n_points, width);
  std::uint32_t* cell = table(std::size_t(width) * n_points);
  std::vector<std::uint32_t> fill(n_points, 0);
  for (std::size_t c = 0; c < cells.size(); ++c)
    for (int r = 0; r < 4; ++r) {
      const std::uint32_t i = cells[c].point[r];
      cell[rows.at(fill[i]++, i)] = static_cast<std::uint32_t>(c);
    }
  return width;
}

// A mesh cell's corner by local index.
struct LocalCorner {
  const std::uint32_t* mesh_point;
  LocalOfId local;
  std::uint32_t* point;
  KF_HD KF_INLINE void operator()(std::size_t q) const { point[q] = local(mesh_point[q]); }
};

} // namespace

template <typename T>
void VolumeTopology<T>::build(const std::vector<VolumeCell>& cells, std::size_t n_points) {
  std::vector<std::uint32_t> count, cell, point;
  std::vector<T> rest, k;
  const exec::Backend b = count_.backend();
  width_ = cell_rows<T>(
      cells, n_points,
      [b](std::size_t n, std::uint32_t w) { return RowLayout::for_backend(b, n, w); },
      [&cell](std::size_t size) {
        cell.assign(size, 0);
        return cell.data();
      },
      count, point, rest, k);
  count_.assign(count);
  cell_.assign(cell);
  point_.assign(point);
  rest_.assign(rest);
  k_.assign(k);
  cells_ = cells.size();
}

template <typename T>
typename VolumeTopology<T>::Mesh VolumeTopology<T>::mesh_rows(exec::Backend b,
                                                              const std::vector<VolumeCell>& cells,
                                                              std::size_t n_points) {
  std::vector<std::uint32_t> count, point;
  std::vector<T> rest, k;
  Mesh m;
  m.width = cell_rows<T>(
      cells, n_points,
      [](std::size_t, std::uint32_t w) {
        return RowLayout{1, w};
      },
      [&m, b](std::size_t size) {
        m.cell = exec::HostReadable<std::uint32_t>(b, size, "knit.mesh.volume.cell");
        return m.cell.data();
      },
      count, point, rest, k);
  m.count = exec::HostReadable<std::uint32_t>(b, count, "knit.mesh.volume.count");
  m.point = exec::HostReadable<std::uint32_t>(b, point, "knit.mesh.volume.point");
  m.rest = exec::HostReadable<T>(b, rest, "knit.mesh.volume.rest");
  m.k = exec::HostReadable<T>(b, k, "knit.mesh.volume.k");
  m.cells = cells.size();
  return m;
}

template <typename T>
void VolumeTopology<T>::localize(const exec::Exec& ex, const Mesh& mesh, const std::uint64_t* id,
                                 const std::uint32_t* local_of_id, std::size_t owned) {
  cells_ = mesh.cells;
  width_ = mesh.width;
  if (rest_.size() != mesh.rest.size()) { // the mesh's constants, by mesh cell index
    rest_.assign(mesh.rest.data(), mesh.rest.size());
    k_.assign(mesh.k.data(), mesh.k.size());
  }
  count_.resize(owned);
  cell_.resize(std::size_t(width_) * owned);
  point_.resize(mesh.point.size());
  exec::for_each(ex, owned,
                 LocalRowGather<std::uint32_t, SameEntry>{mesh.count.data(),
                                                          mesh.cell.data(),
                                                          mesh.rows(),
                                                          id,
                                                          rows(),
                                                          count_.data(),
                                                          cell_.data(),
                                                          {}},
                 "knit.volumes.localize");
  exec::for_each(ex, point_.size(), LocalCorner{mesh.point.data(), {local_of_id}, point_.data()},
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
         rest_.capacity_bytes() + k_.capacity_bytes();
}

template class VolumeTopology<float>;
template class VolumeTopology<double>;

} // namespace kf
