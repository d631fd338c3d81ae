#include "io/PngImage.hpp"

#include "core/Error.hpp"

#include <png.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <memory>

namespace kf::io {

namespace {

struct File {
  std::FILE* f = nullptr;
  ~File() {
    if (f)
      std::fclose(f);
  }
};

[[noreturn]] void on_error(png_structp png, png_const_charp msg) {
  auto* what = static_cast<std::string*>(png_get_error_ptr(png));
  *what = msg ? msg : "libpng error";
  png_longjmp(png, 1);
}

void on_warning(png_structp, png_const_charp) {}

} // namespace

void write_png(const std::string& path, const RgbaImage& image, int compression) {
  if (image.width <= 0 || image.height <= 0 ||
      image.pixels.size() != std::size_t(image.width) * image.height * 4)
    throw Error(path + ": an image of " + std::to_string(image.width) + " x " +
                std::to_string(image.height) + " pixels needs " +
                std::to_string(std::size_t(image.width > 0 ? image.width : 0) *
                               (image.height > 0 ? image.height : 0) * 4) +
                " bytes, not " + std::to_string(image.pixels.size()));
  const std::string tmp = path + ".tmp";
  std::string what;
  {
    File file{std::fopen(tmp.c_str(), "wb")};
    if (!file.f)
      throw Error(tmp + ": cannot open for writing");
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &what, on_error, on_warning);
    png_infop info = png ? png_create_info_struct(png) : nullptr;
    if (!png || !info) {
      png_destroy_write_struct(&png, nullptr);
      throw Error(path + ": libpng could not start");
    }
    std::vector<png_bytep> rows(std::size_t(image.height));
    for (int r = 0; r < image.height; ++r)
      rows[std::size_t(r)] =
          const_cast<png_bytep>(image.pixels.data() + std::size_t(r) * image.width * 4);
    if (setjmp(png_jmpbuf(png))) {
      png_destroy_write_struct(&png, &info);
      std::fclose(file.f);
      file.f = nullptr;
      std::remove(tmp.c_str());
      throw Error(path + ": writing the PNG failed: " + what);
    }
    png_init_io(png, file.f);
    png_set_IHDR(png, info, png_uint_32(image.width), png_uint_32(image.height), 8,
                 PNG_COLOR_TYPE_RGBA, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
                 PNG_FILTER_TYPE_DEFAULT);
    png_set_compression_level(png, std::clamp(compression, 0, 9));
    png_write_info(png, info);
    png_write_image(png, rows.data());
    png_write_end(png, nullptr);
    png_destroy_write_struct(&png, &info);
    if (std::fflush(file.f) != 0)
      throw Error(tmp + ": writing failed (disk full?)");
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec)
    throw Error(path + ": cannot rename " + tmp + " over it: " + ec.message());
}

RgbaImage read_png(const std::string& path) {
  File file{std::fopen(path.c_str(), "rb")};
  if (!file.f)
    throw Error(path + ": cannot open");
  png_byte sig[8];
  if (std::fread(sig, 1, 8, file.f) != 8 || png_sig_cmp(sig, 0, 8) != 0)
    throw Error(path + ": not a PNG file");
  std::string what;
  png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &what, on_error, on_warning);
  png_infop info = png ? png_create_info_struct(png) : nullptr;
  if (!png || !info) {
    png_destroy_read_struct(&png, nullptr, nullptr);
    throw Error(path + ": libpng could not start");
  }
  RgbaImage img;
  std::vector<png_bytep> rows;
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_read_struct(&png, &info, nullptr);
    throw Error(path + ": reading the PNG failed: " + what);
  }
  png_init_io(png, file.f);
  png_set_sig_bytes(png, 8);
  png_read_info(png, info);
  const int depth = png_get_bit_depth(png, info), type = png_get_color_type(png, info);
  if (depth != 8 || (type != PNG_COLOR_TYPE_RGB && type != PNG_COLOR_TYPE_RGBA)) {
    png_destroy_read_struct(&png, &info, nullptr);
    throw Error(path + ": an 8-bit RGB or RGBA PNG was expected (bit depth " +
                std::to_string(depth) + ", colour type " + std::to_string(type) + ")");
  }
  if (type == PNG_COLOR_TYPE_RGB)
    png_set_filler(png, 0xFF, PNG_FILLER_AFTER);
  png_read_update_info(png, info);
  img.width = int(png_get_image_width(png, info));
  img.height = int(png_get_image_height(png, info));
  img.pixels.resize(std::size_t(img.width) * img.height * 4);
  rows.resize(std::size_t(img.height));
  for (int r = 0; r < img.height; ++r)
    rows[std::size_t(r)] = img.pixels.data() + std::size_t(r) * img.width * 4;
  png_read_image(png, rows.data());
  png_read_end(png, nullptr);
  png_destroy_read_struct(&png, &info, nullptr);
  return img;
}

} // namespace kf::io
