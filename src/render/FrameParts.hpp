#pragma once
// A snapshot read for sort-last rendering, each rank its share of the file (parallel HDF5:
// io::read_snapshot_share) and then its region's fluid: the phases a frame draws whole (knit,
// yarns, walls) gathered to every rank, the fluid's rows routed to the ranks whose region (a
// k-d split of the whole frame's drawn points) or its halo (what the region's surface reads)
// holds them, in the file's order. The whole fluid's box and spacing go to the renderer, so a
// part draws what the whole frame's drawing draws there.
#include "io/Frame.hpp"
#include "render/SnapshotRender.hpp"
#include "render/SpaceSplit.hpp"

#include <mpi.h>

#include <cstddef>
#include <string>
#include <vector>

namespace kf::render {

struct FramePart {
  io::Frame frame;             // the fluid this rank's; the other phases whole
  std::vector<Region> regions; // a rank each
  std::size_t fluid_read = 0;  // fluid rows this rank read (its share of the file)
  std::size_t fluid_held = 0;  // ... and holds to draw (its region's and halo's)
  std::size_t fluid_total = 0;
};

/// Collective over `comm`. The k-d split takes every drawn point up to 2M of them, then every
/// k-th (the same on every rank). A kf::Error names the file where a read or a phase fails.
FramePart read_frame_part(MPI_Comm comm, const std::string& path, SnapshotRenderer& renderer);

} // namespace kf::render
