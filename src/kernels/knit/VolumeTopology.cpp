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

template <typename T>
void VolumeTopology<T>::build(const std::vector<VolumeCell>& cells, std::size_t n_points) {
  std::vector<std::uint32_t> count(n_points, 0), point;
  std::vector<T> rest, k;
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
  const RowLayout rows = RowLayout::for_backend(count_.backend(), n_points, width);
  std::vector<std::uint32_t> cell(std::size_t(width) * n_points, 0), fill(n_points, 0);
  for (std::size_t c = 0; c < cells.size(); ++c)
    for (int r = 0; r < 4; ++r) {
      const std::uint32_t i = cells[c].point[r];
      cell[rows.at(fill[i]++, i)] = static_cast<std::uint32_t>(c);
    }
  count_.assign(count);
  cell_.assign(cell);
  point_.assign(point);
  rest_.assign(rest);
  k_.assign(k);
  cells_ = cells.size();
  width_ = width;
}

namespace {

// A mesh cell's corner by local index.
struct LocalCorner {
  const std::uint32_t* mesh_point;
  LocalOfId local;
  std::uint32_t* point;
  KF_HD KF_INLINE void operator()(std::size_t q) const { point[q] = local(mesh_point[q]); }
};

} // namespace

template <typename T>
void VolumeTopology<T>::localize(const exec::Exec& ex, const VolumeTopology& mesh,
                                 const std::uint64_t* id, const std::uint32_t* local_of_id,
                                 std::size_t owned, std::size_t n) {
  cells_ = mesh.cells_;
  width_ = mesh.width_;
  if (rest_.size() != mesh.rest_.size()) { // the mesh's constants, by mesh cell index
    rest_.resize(mesh.rest_.size());
    rest_.copy_from(mesh.rest_, mesh.rest_.size());
    k_.resize(mesh.k_.size());
    k_.copy_from(mesh.k_, mesh.k_.size());
  }
  count_.resize(n);
  cell_.resize(std::size_t(width_) * n);
  point_.resize(mesh.point_.size());
  exec::for_each(ex, n,
                 LocalRowGather<std::uint32_t, SameEntry>{mesh.count_.data(),
                                                          mesh.cell_.data(),
                                                          mesh.rows(),
                                                          id,
                                                          owned,
                                                          rows(),
                                                          count_.data(),
                                                          cell_.data(),
                                                          {}},
                 "knit.volumes.localize");
  exec::for_each(ex, point_.size(), LocalCorner{mesh.point_.data(), {local_of_id}, point_.data()},
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
