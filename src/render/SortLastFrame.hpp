#pragma once
// A frame drawn over ranks, sort-last (paper §6; DESIGN §8): each rank draws the part of the
// frame in its region of a k-d split, and the parts are composited into the root's picture.
// Opaque layers (and the translucent water's, each the nearest of its kind) combine by depth
// (binary swap); the volumetric yarns, translucent, are drawn by each rank after the opaque
// composite's depth is shared (the strips gathered on every rank), cut at their region's faces,
// and their layers combine by the ordered "over" front to back (the regions' visibility order
// from the eye, ordered binary swap). Every rank sends about one image a layer, whatever the
// rank count.
#include "comm/BinarySwap.hpp"
#include "io/Frame.hpp"
#include "io/PngImage.hpp"
#include "render/Camera.hpp"
#include "render/SnapshotRender.hpp"
#include "render/SpaceSplit.hpp"

#include <mpi.h>

#include <vector>

namespace kf::render {

struct SortLastTimes {
  double draw = 0;      // the part's opaque scene (and water layers) [s]
  double composite = 0; // their swap, the depth shared, the gather
  double yarns = 0;     // the part's yarn layer
  double yarn_composite = 0;
  double resolve = 0;         // the root's picture from the composites
  std::size_t bytes_sent = 0; // by this rank, all layers
};

/// Collective over `comm` (a rank a region of `regions`, kd_split's). `frame` holds at least
/// what this rank's region draws (FramePart's frame, or the whole). The picture on `root`;
/// empty elsewhere.
io::RgbaImage draw_sort_last(MPI_Comm comm, SnapshotRenderer& renderer, const io::Frame& frame,
                             const Camera& camera, const std::vector<Region>& regions,
                             SortLastTimes* times = nullptr, int root = 0);

} // namespace kf::render
