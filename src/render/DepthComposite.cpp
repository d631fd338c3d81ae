#include "render/DepthComposite.hpp"

#include "core/Error.hpp"

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

io::RgbaImage colour_of(const std::vector<DepthPixel>& pixels, int width, int height) {
  io::RgbaImage img{width, height, std::vector<std::uint8_t>(4 * pixels.size())};
  for (std::size_t k = 0; k < pixels.size(); ++k)
    std::memcpy(&img.pixels[4 * k], pixels[k].rgba, 4);
  return img;
}

} // namespace kf::render
