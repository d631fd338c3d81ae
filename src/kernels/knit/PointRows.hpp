#pragma once
// Which row of a rank's table each mesh point has (host side, where a rank's rows are built:
// SpringTopology::host_rows, VolumeTopology::host_rows).
#include "core/Error.hpp"
#include "kernels/knit/LocalRows_K.hpp"

#include <cstdint>
#include <string>
#include <vector>

namespace kf {

/// row_of[p] = k where ids[k] = p, kAbsentPoint for points not listed. Rejects an id past
/// n_points or listed twice (`what` names the table).
inline std::vector<std::uint32_t> rows_of_points(const std::vector<std::uint64_t>& ids,
                                                 std::size_t n_points, const char* what) {
  std::vector<std::uint32_t> row_of(n_points, kAbsentPoint);
  for (std::size_t k = 0; k < ids.size(); ++k) {
    if (ids[k] >= n_points || row_of[ids[k]] != kAbsentPoint)
      throw Error(std::string(what) + ": point " + std::to_string(ids[k]) + " is not one of " +
                  std::to_string(n_points) + " or is listed twice");
    row_of[ids[k]] = static_cast<std::uint32_t>(k);
  }
  return row_of;
}

} // namespace kf
