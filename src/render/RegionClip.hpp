#pragma once
// A sort-last part's drawing cut at its region's faces: the programs built with_region_clip
// (shaders/region_clip.glsl inserted after their #version) compute the distances to the box's
// six faces; clip_to turns the GPU's clipping on for a region, or off.
#include "render/SpaceSplit.hpp"

#include <string>

namespace kf::render {

/// `source` with region_clip.glsl after its #version line (its vertex shader calls
/// clip_to_region(world)).
std::string with_region_clip(const char* source);

/// With `region`: program p's box set to it (infinite faces as far as a float goes) and the six
/// clip distances on; without: off. Use the program first.
void clip_to(unsigned program, const Region* region);

} // namespace kf::render
