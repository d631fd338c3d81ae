#pragma once
// Where a frame is drawn without a window: a framebuffer object with an RGBA8 colour and a
// 32-bit float depth attachment, both textures (a later pass samples them: the water's resolve;
// WaterLayers writes a composite into them), read back into host memory (rows top first, as
// images are stored). Float depth goes to the host and back unchanged, so a composite's pixels
// resolve as the GPU's own.
#include <algorithm>
#include <cstdint>
#include <vector>

namespace kf::render {

/// GL's rows run bottom up, images' top down: reverses the order of `v`'s rows of `row` elements.
template <typename T>
void flip_rows(std::vector<T>& v, std::size_t row) {
  const std::size_t rows = v.size() / row;
  for (std::size_t r = 0; r < rows / 2; ++r)
    std::swap_ranges(v.begin() + std::ptrdiff_t(r * row), v.begin() + std::ptrdiff_t((r + 1) * row),
                     v.begin() + std::ptrdiff_t((rows - 1 - r) * row));
}

class OffscreenTarget {
public:
  /// Needs a current context (EglContext). A kf::Error names the framebuffer's status if the
  /// driver refuses the attachments. half_float: the colour as 4 half floats a pixel (a
  /// translucent layer blended over transparent black, composited before it meets 8 bits).
  OffscreenTarget(int width, int height, bool half_float = false);
  ~OffscreenTarget();
  OffscreenTarget(const OffscreenTarget&) = delete;
  OffscreenTarget& operator=(const OffscreenTarget&) = delete;

  /// Draws go here from now on, over the whole target.
  void bind() const;
  /// The colour attachment, 4 bytes a pixel, the top row first.
  std::vector<std::uint8_t> read_rgba() const;
  /// The colour attachment as half floats (4 a pixel), the top row first.
  std::vector<std::uint16_t> read_rgba_half() const;
  /// The depth attachment in [0, 1], the top row first.
  std::vector<float> read_depth() const;
  /// Replaces both attachments (a composite of parts): 4 bytes and a depth a pixel, the top row
  /// first.
  void write(std::vector<std::uint8_t> rgba, std::vector<float> depth);
  /// Replaces the depth attachment alone (a pixel a value, the top row first).
  void write_depth(std::vector<float> depth);
  unsigned colour_texture() const { return colour_; }
  unsigned depth_texture() const { return depth_; }
  int width() const { return width_; }
  int height() const { return height_; }

private:
  int width_, height_;
  unsigned fbo_ = 0, colour_ = 0, depth_ = 0;
};

} // namespace kf::render
