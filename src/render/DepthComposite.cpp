#include "render/DepthComposite.hpp"

#include "core/Error.hpp"

#include <glm/glm.hpp>
#include <glm/gtc/packing.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>

namespace kf::render {

std::vector<DepthPixel> depth_pixels(const io::RgbaImage& colour, const std::vector<float>& depth) {
  const std::size_t n = std::size_t(colour.width) * std::size_t(colour.height);
  if (colour.pixels.size() != 4 * n || depth.size() != n)
    throw Error("render: a " + std::to_string(colour.width) + " x " +
                std::to_string(colour.height) + " image with " + std::to_string(depth.size()) +
                " depth values");
  std::vector<DepthPixel> out(n);
  for (std::size_t k = 0; k < n; ++k) {
    std::memcpy(out[k].rgba, &colour.pixels[4 * k], 4);
    out[k].depth = depth[k];
  }
  return out;
}

void keep_nearer(DepthPixel* mine, const DepthPixel* theirs, std::size_t count) {
  for (std::size_t k = 0; k < count; ++k)
    if (theirs[k].depth < mine[k].depth)
      mine[k] = theirs[k];
}

void keep_nearer(LayeredPixel* mine, const LayeredPixel* theirs, std::size_t count) {
  for (std::size_t k = 0; k < count; ++k) {
    LayeredPixel& m = mine[k];
    const LayeredPixel& t = theirs[k];
    if (t.opaque.depth < m.opaque.depth)
      m.opaque = t.opaque;
    if (t.water.front < m.water.front) {
      std::memcpy(m.water.surface, t.water.surface, sizeof m.water.surface);
      std::memcpy(m.water.normal, t.water.normal, sizeof m.water.normal);
      m.water.front = t.water.front;
    }
    if (t.water.back < m.water.back)
      m.water.back = t.water.back;
  }
}

namespace {

glm::vec4 unpacked(const YarnPixel& p) {
  return {glm::unpackHalf1x16(p.rgba[0]), glm::unpackHalf1x16(p.rgba[1]),
          glm::unpackHalf1x16(p.rgba[2]), glm::unpackHalf1x16(p.rgba[3])};
}

/// No yarn over this pixel: its layer is still the transparent black it was cleared to.
bool clear(const YarnPixel& p) {
  return p.rgba[0] == 0 && p.rgba[1] == 0 && p.rgba[2] == 0 && p.rgba[3] == 0;
}

} // namespace

void yarns_over(YarnPixel* mine, const YarnPixel* theirs, std::size_t count, bool theirs_in_front) {
  for (std::size_t k = 0; k < count; ++k) {
    const YarnPixel& f = theirs_in_front ? theirs[k] : mine[k];
    const YarnPixel& b = theirs_in_front ? mine[k] : theirs[k];
    if (clear(b)) {
      // Nothing behind (the common case: most of a part's pixels hold no yarn): front as is.
      const float depth = std::min(f.depth, b.depth);
      mine[k] = f;
      mine[k].depth = depth;
      continue;
    }
    const glm::vec4 front = unpacked(f), back = unpacked(b);
    const glm::vec4 c = front + (1.0f - front.a) * back;
    YarnPixel out;
    for (int i = 0; i < 4; ++i)
      out.rgba[i] = glm::packHalf1x16(c[i]);
    out.depth = std::min(f.depth, b.depth);
    mine[k] = out;
  }
}

void put_yarns_over(DepthPixel& opaque, const YarnPixel& yarns) {
  opaque.depth = std::min(opaque.depth, yarns.depth);
  if (clear(yarns))
    return;
  const glm::vec4 y = unpacked(yarns);
  for (int i = 0; i < 4; ++i) {
    const float c = y[i] + (1.0f - y.a) * float(opaque.rgba[i]) / 255.0f;
    opaque.rgba[i] = std::uint8_t(std::lround(255.0f * std::clamp(c, 0.0f, 1.0f)));
  }
}

io::RgbaImage colour_of(const std::vector<DepthPixel>& pixels, int width, int height) {
  io::RgbaImage img{width, height, std::vector<std::uint8_t>(4 * pixels.size())};
  for (std::size_t k = 0; k < pixels.size(); ++k)
    std::memcpy(&img.pixels[4 * k], pixels[k].rgba, 4);
  return img;
}

} // namespace kf::render
