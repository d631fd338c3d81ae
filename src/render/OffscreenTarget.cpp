#include "render/OffscreenTarget.hpp"

#include "core/Error.hpp"

#include <epoxy/gl.h>

#include <algorithm>
#include <string>

namespace kf::render {

OffscreenTarget::OffscreenTarget(int width, int height, bool half_float)
    : width_(width), height_(height) {
  if (width <= 0 || height <= 0)
    throw Error("render: an image of " + std::to_string(width) + " x " + std::to_string(height) +
                " pixels");
  glCreateFramebuffers(1, &fbo_);
  glCreateTextures(GL_TEXTURE_2D, 1, &colour_);
  glCreateTextures(GL_TEXTURE_2D, 1, &depth_);
  glTextureStorage2D(colour_, 1, half_float ? GL_RGBA16F : GL_RGBA8, width, height);
  glTextureStorage2D(depth_, 1, GL_DEPTH_COMPONENT32F, width, height);
  for (unsigned t : {colour_, depth_}) { // read texel by texel (texelFetch), never filtered
    glTextureParameteri(t, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTextureParameteri(t, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  }
  glNamedFramebufferTexture(fbo_, GL_COLOR_ATTACHMENT0, colour_, 0);
  glNamedFramebufferTexture(fbo_, GL_DEPTH_ATTACHMENT, depth_, 0);
  const GLenum status = glCheckNamedFramebufferStatus(fbo_, GL_FRAMEBUFFER);
  if (status != GL_FRAMEBUFFER_COMPLETE) {
    glDeleteFramebuffers(1, &fbo_);
    glDeleteTextures(1, &colour_);
    glDeleteTextures(1, &depth_);
    throw Error("render: the " + std::to_string(width) + " x " + std::to_string(height) +
                " framebuffer is incomplete (status 0x" +
                [&] {
                  char b[16];
                  std::snprintf(b, sizeof b, "%04x", status);
                  return std::string(b);
                }() +
                ")");
  }
}

OffscreenTarget::~OffscreenTarget() {
  glDeleteFramebuffers(1, &fbo_);
  glDeleteTextures(1, &colour_);
  glDeleteTextures(1, &depth_);
}

void OffscreenTarget::bind() const {
  glBindFramebuffer(GL_FRAMEBUFFER, fbo_);
  glViewport(0, 0, width_, height_);
}

namespace {

/// The framebuffer's colour read back as `type` (4 values a pixel), the top row first.
template <typename T>
std::vector<T> read_colour(unsigned fbo, int width, int height, GLenum type) {
  std::vector<T> px(std::size_t(width) * std::size_t(height) * 4);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glNamedFramebufferReadBuffer(fbo, GL_COLOR_ATTACHMENT0);
  glBindFramebuffer(GL_READ_FRAMEBUFFER, fbo);
  glReadPixels(0, 0, width, height, GL_RGBA, type, px.data());
  flip_rows(px, std::size_t(width) * 4);
  return px;
}

} // namespace

std::vector<std::uint8_t> OffscreenTarget::read_rgba() const {
  return read_colour<std::uint8_t>(fbo_, width_, height_, GL_UNSIGNED_BYTE);
}

std::vector<std::uint16_t> OffscreenTarget::read_rgba_half() const {
  return read_colour<std::uint16_t>(fbo_, width_, height_, GL_HALF_FLOAT);
}

std::vector<float> OffscreenTarget::read_depth() const {
  std::vector<float> d(std::size_t(width_) * height_);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glBindFramebuffer(GL_READ_FRAMEBUFFER, fbo_);
  glReadPixels(0, 0, width_, height_, GL_DEPTH_COMPONENT, GL_FLOAT, d.data());
  flip_rows(d, std::size_t(width_));
  return d;
}

void OffscreenTarget::write(std::vector<std::uint8_t> rgba, std::vector<float> depth) {
  const std::size_t n = std::size_t(width_) * std::size_t(height_);
  if (rgba.size() != 4 * n || depth.size() != n)
    throw Error("render: " + std::to_string(depth.size()) + " pixels written into a " +
                std::to_string(width_) + " x " + std::to_string(height_) + " target");
  flip_rows(rgba, 4 * std::size_t(width_));
  flip_rows(depth, std::size_t(width_));
  glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  glTextureSubImage2D(colour_, 0, 0, 0, width_, height_, GL_RGBA, GL_UNSIGNED_BYTE, rgba.data());
  glTextureSubImage2D(depth_, 0, 0, 0, width_, height_, GL_DEPTH_COMPONENT, GL_FLOAT, depth.data());
  glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
}

void OffscreenTarget::write_depth(std::vector<float> depth) {
  if (depth.size() != std::size_t(width_) * std::size_t(height_))
    throw Error("render: " + std::to_string(depth.size()) + " depths written into a " +
                std::to_string(width_) + " x " + std::to_string(height_) + " target");
  flip_rows(depth, std::size_t(width_));
  glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  glTextureSubImage2D(depth_, 0, 0, 0, width_, height_, GL_DEPTH_COMPONENT, GL_FLOAT, depth.data());
  glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
}

} // namespace kf::render
