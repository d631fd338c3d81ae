#include "kernels/knit/VolumeTopology.hpp"

#include "core/Error.hpp"

#include <string>

namespace kf {

template <typename T>
VolumeTopology<T>::VolumeTopology(exec::Backend b)
    : start_(b, 0, "knit.volume.start"), cell_(b, 0, "knit.volume.cell"),
      point_(b, 0, "knit.volume.point"), rest_(b, 0, "knit.volume.rest"),
      k_(b, 0, "knit.volume.k") {}

template <typename T>
void VolumeTopology<T>::build(const std::vector<VolumeCell>& cells, std::size_t n_points) {
  std::vector<std::uint32_t> start(n_points + 1, 0), point;
  std::vector<T> rest, k;
  for (const VolumeCell& c : cells) {
    for (int r = 0; r < 4; ++r) {
      if (c.point[r] >= n_points)
        throw Error("volume cell point " + std::to_string(c.point[r]) + " is not one of " +
                    std::to_string(n_points));
      for (int q = 0; q < r; ++q)
        if (c.point[q] == c.point[r])
          throw Error("volume cell with a repeated point " + std::to_string(c.point[r]));
      ++start[c.point[r] + 1];
      point.push_back(c.point[r]);
    }
    rest.push_back(static_cast<T>(c.rest_volume));
    k.push_back(static_cast<T>(c.k));
  }
  for (std::size_t i = 0; i < n_points; ++i)
    start[i + 1] += start[i];
  std::vector<std::uint32_t> cell(start[n_points]), fill(start.begin(), start.end() - 1);
  for (std::size_t c = 0; c < cells.size(); ++c)
    for (int r = 0; r < 4; ++r)
      cell[fill[cells[c].point[r]]++] = static_cast<std::uint32_t>(c);
  start_.assign(start);
  cell_.assign(cell);
  point_.assign(point);
  rest_.assign(rest);
  k_.assign(k);
  cells_ = cells.size();
}

template <typename T>
VolumeView<T> VolumeTopology<T>::view() const {
  if (cells_ == 0)
    return {};
  return {start_.data(), cell_.data(), point_.data(), rest_.data(), k_.data(), start_.size() - 1};
}

template <typename T>
std::size_t VolumeTopology<T>::bytes() const {
  return start_.capacity_bytes() + cell_.capacity_bytes() + point_.capacity_bytes() +
         rest_.capacity_bytes() + k_.capacity_bytes();
}

template class VolumeTopology<float>;
template class VolumeTopology<double>;

} // namespace kf
