#pragma once
#include "core/HostDevice.hpp"
#include "kernels/knit/RowLayout.hpp"

#include <cstddef>
#include <cstdint>

namespace kf {

/// A mesh index with no local point here (neither owned nor a ghost), in local_of_id and so in
/// the localized rows.
inline constexpr std::uint32_t kAbsentPoint = 0xFFFFFFFFu;

/// Gathers a per-point table's rows for a rank's owned points from the rank's rows on the host
/// (row k the k-th local point's, HostRows), each entry through `local` (mesh indices inside it
/// made local); ghosts have no rows (theirs are their owners'). Springs and volume cells share
/// it: entry e of point p sits at rows.at(e, p) in both (RowLayout).
template <typename Entry, typename Local>
struct LocalRowGather {
  const std::uint32_t* from_count;
  const Entry* from_entry;
  RowLayout from_rows;
  RowLayout rows;
  std::uint32_t* count;
  Entry* entry;
  Local local;
  KF_HD KF_INLINE void operator()(std::size_t k) const {
    const std::uint32_t c = from_count[k];
    count[k] = c;
    for (std::uint32_t e = 0; e < c; ++e)
      entry[rows.at(e, k)] = local(from_entry[from_rows.at(e, k)]);
  }
};

/// A mesh point index made local (the volume cells' corners, the springs' other ends).
struct LocalOfId {
  const std::uint32_t* local_of_id;
  KF_HD KF_INLINE std::uint32_t operator()(std::uint32_t mesh_point) const {
    return local_of_id[mesh_point];
  }
};

/// An entry that names no point (a volume cell's index: its corners are made local apart).
struct SameEntry {
  template <typename Entry>
  KF_HD KF_INLINE Entry operator()(const Entry& e) const {
    return e;
  }
};

} // namespace kf
