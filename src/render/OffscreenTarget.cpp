#include "render/OffscreenTarget.hpp"

#include "core/Error.hpp"

#include <epoxy/gl.h>

#include <algorithm>
#include <string>

namespace kf::render {

OffscreenTarget::OffscreenTarget(int width, int height) : width_(width), height_(height) {
  if (width <= 0 || height <= 0)
    throw Error("render: an image of " + std::to_string(width) + " x " + std::to_string(height) +
                " pixels");
  glCreateFramebuffers(1, &fbo_);
  glCreateRenderbuffers(1, &colour_);
  glCreateRenderbuffers(1, &depth_);
  glNamedRenderbufferStorage(colour_, GL_RGBA8, width, height);
  glNamedRenderbufferStorage(depth_, GL_DEPTH_COMPONENT24, width, height);
  glNamedFramebufferRenderbuffer(fbo_, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, colour_);
  glNamedFramebufferRenderbuffer(fbo_, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, depth_);
  const GLenum status = glCheckNamedFramebufferStatus(fbo_, GL_FRAMEBUFFER);
  if (status != GL_FRAMEBUFFER_COMPLETE) {
    glDeleteFramebuffers(1, &fbo_);
    glDeleteRenderbuffers(1, &colour_);
    glDeleteRenderbuffers(1, &depth_);
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
  glDeleteRenderbuffers(1, &colour_);
  glDeleteRenderbuffers(1, &depth_);
}

void OffscreenTarget::bind() const {
  glBindFramebuffer(GL_FRAMEBUFFER, fbo_);
  glViewport(0, 0, width_, height_);
}

namespace {

/// GL's rows run bottom up; images top down.
template <typename T>
void flip_rows(std::vector<T>& v, std::size_t row) {
  const std::size_t rows = v.size() / row;
  for (std::size_t r = 0; r < rows / 2; ++r)
    std::swap_ranges(v.begin() + r * row, v.begin() + (r + 1) * row,
                     v.begin() + (rows - 1 - r) * row);
}

} // namespace

std::vector<std::uint8_t> OffscreenTarget::read_rgba() const {
  std::vector<std::uint8_t> px(std::size_t(width_) * height_ * 4);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glNamedFramebufferReadBuffer(fbo_, GL_COLOR_ATTACHMENT0);
  glBindFramebuffer(GL_READ_FRAMEBUFFER, fbo_);
  glReadPixels(0, 0, width_, height_, GL_RGBA, GL_UNSIGNED_BYTE, px.data());
  flip_rows(px, std::size_t(width_) * 4);
  return px;
}

std::vector<float> OffscreenTarget::read_depth() const {
  std::vector<float> d(std::size_t(width_) * height_);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glBindFramebuffer(GL_READ_FRAMEBUFFER, fbo_);
  glReadPixels(0, 0, width_, height_, GL_DEPTH_COMPONENT, GL_FLOAT, d.data());
  flip_rows(d, std::size_t(width_));
  return d;
}

} // namespace kf::render
