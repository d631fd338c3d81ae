#pragma once
// Opaque layers composited by depth (sort-last rendering): a pixel of a rank's part of a frame as
// a record of its colour and depth, and the fold that keeps the nearer. The message passing is
// comm::binary_swap's; this is what it folds.
#include "io/PngImage.hpp"

#include <cstddef>
#include <cstdint>
#include <vector>

namespace kf::render {

struct DepthPixel {
  std::uint8_t rgba[4];
  float depth; // [0, 1]; 1 where nothing was drawn
};
static_assert(sizeof(DepthPixel) == 8);

std::vector<DepthPixel> depth_pixels(const io::RgbaImage& colour, const std::vector<float>& depth);
/// mine[k] = theirs[k] where theirs is strictly nearer: ties keep mine, so a pixel both ranks
/// left empty keeps its background.
void keep_nearer(DepthPixel* mine, const DepthPixel* theirs, std::size_t count);
io::RgbaImage colour_of(const std::vector<DepthPixel>& pixels, int width, int height);

} // namespace kf::render
