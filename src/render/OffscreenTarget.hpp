#pragma once
// Where a frame is drawn without a window: a framebuffer object with an RGBA8 colour and a
// 24-bit depth attachment, read back into host memory (rows top first, as images are stored).
#include <cstdint>
#include <vector>

namespace kf::render {

class OffscreenTarget {
public:
  /// Needs a current context (EglContext). A kf::Error names the framebuffer's status if the
  /// driver refuses the attachments.
  OffscreenTarget(int width, int height);
  ~OffscreenTarget();
  OffscreenTarget(const OffscreenTarget&) = delete;
  OffscreenTarget& operator=(const OffscreenTarget&) = delete;

  /// Draws go here from now on, over the whole target.
  void bind() const;
  /// The colour attachment, 4 bytes a pixel, the top row first.
  std::vector<std::uint8_t> read_rgba() const;
  /// The depth attachment in [0, 1], the top row first.
  std::vector<float> read_depth() const;
  int width() const { return width_; }
  int height() const { return height_; }

private:
  int width_, height_;
  unsigned fbo_ = 0, colour_ = 0, depth_ = 0;
};

} // namespace kf::render
