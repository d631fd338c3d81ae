#include "render/SortLastFrame.hpp"

#include "core/Error.hpp"
#include "render/DepthComposite.hpp"
#include "render/OffscreenTarget.hpp"

#include <chrono>
#include <numeric>
#include <string>

namespace kf::render {

namespace {

float opaque_depth(const DepthPixel& p) {
  return p.depth;
}
float opaque_depth(const LayeredPixel& p) {
  return p.opaque.depth;
}

/// The parts' pixels folded by depth into the root's; with `depth` (the yarns to come), the
/// composite's opaque depth on every rank too.
template <typename Pixel>
comm::BinarySwapStats composite_by_depth(MPI_Comm comm, std::vector<Pixel>& px, int root,
                                         std::vector<float>* depth) {
  int size = 1;
  MPI_Comm_size(comm, &size);
  std::vector<int> ranks(static_cast<std::size_t>(size));
  std::iota(ranks.begin(), ranks.end(), 0); // a depth test folds in any order
  comm::BinarySwapStats st = comm::swap_strips(
      comm, px.data(), px.size(), sizeof(Pixel), ranks,
      [](void* mine, const void* theirs, std::size_t n, bool) {
        keep_nearer(static_cast<Pixel*>(mine), static_cast<const Pixel*>(theirs), n);
      });
  if (depth) {
    std::vector<float> strip;
    strip.reserve(st.last - st.first);
    for (std::size_t k = st.first; k < st.last; ++k)
      strip.push_back(opaque_depth(px[k]));
    depth->resize(px.size());
    comm::allgather_strips(comm, strip.data(), st.first, st.last, sizeof(float), depth->data(),
                           px.size());
    st.bytes_sent += strip.size() * sizeof(float) * std::size_t(size - 1);
  }
  comm::gather_strips(comm, px.data(), sizeof(Pixel), st, root);
  return st;
}

} // namespace

io::RgbaImage draw_sort_last(MPI_Comm comm, SnapshotRenderer& renderer, const io::Frame& frame,
                             const Camera& camera, const std::vector<Region>& regions,
                             SortLastTimes* times, int root) {
  int rank = 0, size = 1;
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &size);
  if (regions.size() != std::size_t(size))
    throw Error("render: " + std::to_string(regions.size()) + " regions for " +
                std::to_string(size) + " ranks");
  using clock = std::chrono::steady_clock;
  SortLastTimes t;
  const auto seconds = [](clock::time_point a, clock::time_point b) {
    return std::chrono::duration<double>(b - a).count();
  };
  const Region& mine = regions[std::size_t(rank)];
  // Every rank decides alike: the yarn phase is whole on every rank.
  const bool yarns = renderer.yarn_layer(frame);
  std::vector<float> depth;
  std::vector<DepthPixel> opaque;
  std::vector<LayeredPixel> layers;
  auto t0 = clock::now();
  if (renderer.translucent())
    layers = renderer.draw_layers(frame, camera, &mine);
  else {
    const io::RgbaImage part = renderer.draw(frame, camera, &mine);
    opaque = depth_pixels(part, renderer.depth());
  }
  auto t1 = clock::now();
  t.draw = seconds(t0, t1);
  const comm::BinarySwapStats st =
      renderer.translucent() ? composite_by_depth(comm, layers, root, yarns ? &depth : nullptr)
                             : composite_by_depth(comm, opaque, root, yarns ? &depth : nullptr);
  t.bytes_sent += st.bytes_sent;
  auto t2 = clock::now();
  t.composite = seconds(t1, t2);
  std::vector<YarnPixel> yarn_px;
  if (yarns) {
    // The water's layers are in GL's row order (bottom up): the depth to the image's.
    if (renderer.translucent())
      flip_rows(depth, std::size_t(renderer.width()));
    yarn_px = renderer.draw_yarn_layer(camera, mine, depth);
    auto t3 = clock::now();
    t.yarns = seconds(t2, t3);
    const comm::BinarySwapStats ys = comm::ordered_binary_swap(
        comm, yarn_px.data(), yarn_px.size(), sizeof(YarnPixel),
        visibility_order(regions, camera.eye),
        [](void* mine, const void* theirs, std::size_t n, bool theirs_in_front) {
          yarns_over(static_cast<YarnPixel*>(mine), static_cast<const YarnPixel*>(theirs), n,
                     theirs_in_front);
        },
        root);
    t.bytes_sent += ys.bytes_sent;
    t2 = clock::now();
    t.yarn_composite = seconds(t3, t2);
  }
  io::RgbaImage picture;
  if (rank == root)
    picture = renderer.translucent() ? renderer.resolve(std::move(layers), yarn_px, camera)
                                     : renderer.composite_picture(std::move(opaque), yarn_px);
  t.resolve = seconds(t2, clock::now());
  if (times)
    *times = t;
  return picture;
}

} // namespace kf::render
