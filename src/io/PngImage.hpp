#pragma once
// PNG files of 8-bit RGBA pixels (libpng), the render stage's output.
#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace kf::io {

struct RgbaImage {
  int width = 0, height = 0;
  std::vector<std::uint8_t> pixels; // 4 bytes a pixel, rows top first
};

/// Writes `path` through a temporary file renamed over it: a failed write leaves any earlier
/// file whole. A kf::Error names the file and what failed. `compression`: zlib's level, 0-9
/// (1: a film's frames, 3-4 times faster than the default 6 for files a fifth larger).
void write_png(const std::string& path, const RgbaImage& image, int compression = 6);
/// Reads an 8-bit RGB or RGBA PNG (RGB gets alpha 255). A kf::Error names the file.
RgbaImage read_png(const std::string& path);

} // namespace kf::io
