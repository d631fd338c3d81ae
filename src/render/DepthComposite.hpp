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

/// A pixel of the translucent water's layers (render/WaterLayers): the nearest front face's own
/// light (rgb: the mirrored environment and the highlight; a: Fresnel's share F), its normal
/// (view space, octahedral, two half floats) and depth; the nearest back face's depth. Depth 1:
/// no such face.
struct WaterPixel {
  std::uint8_t surface[4];
  std::uint16_t normal[2];
  float front, back;
};
static_assert(sizeof(WaterPixel) == 16);

/// A pixel of a part of a frame with translucent water: the opaque scene's and the water's. The
/// composite of the parts' records is the whole frame's (each layer the nearest of its kind),
/// which the water's resolve turns into the picture.
struct LayeredPixel {
  DepthPixel opaque;
  WaterPixel water;
};
static_assert(sizeof(LayeredPixel) == 24);

/// A pixel of a part's volumetric yarns (sort-last): their slices blended back to front over
/// transparent black, premultiplied (half floats: parts are folded by "over" before the 8 bits
/// of the picture), and their cores' nearest depth (the tubes'; 1: none). The parts are
/// folded in the order they lie from the eye (comm::ordered_binary_swap).
struct YarnPixel {
  std::uint16_t rgba[4];
  float depth;
};
static_assert(sizeof(YarnPixel) == 12);

std::vector<DepthPixel> depth_pixels(const io::RgbaImage& colour, const std::vector<float>& depth);
/// mine[k] = theirs[k] where theirs is strictly nearer: ties keep mine, so a pixel both ranks
/// left empty keeps its background.
void keep_nearer(DepthPixel* mine, const DepthPixel* theirs, std::size_t count);
/// Each layer the nearer: the opaque scene's, the water's front face (its light, normal and
/// depth together) and its back face; ties keep mine.
void keep_nearer(LayeredPixel* mine, const LayeredPixel* theirs, std::size_t count);
/// Folds two parts' yarns: the one in front "over" the other (colour front + (1 - its alpha)
/// back), the nearer core; the result in `mine`.
void yarns_over(YarnPixel* mine, const YarnPixel* theirs, std::size_t count, bool theirs_in_front);
/// The yarns over the opaque scene behind them: colour y + (1 - y's alpha) opaque, rounded to 8
/// bits; the depth the nearer of the scene's and the cores'.
void put_yarns_over(DepthPixel& opaque, const YarnPixel& yarns);
io::RgbaImage colour_of(const std::vector<DepthPixel>& pixels, int width, int height);

} // namespace kf::render
