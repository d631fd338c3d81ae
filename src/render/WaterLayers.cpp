#include "render/WaterLayers.hpp"

#include "core/Error.hpp"
#include "render/Shaders.hpp"

#include <epoxy/gl.h>
#include <glm/gtc/type_ptr.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>

namespace kf::render {

glm::vec3 absorption_for(const glm::vec3& tint, double depth) {
  if (!(depth > 0))
    throw Error("render: the water's absorption depth must be positive, not " +
                std::to_string(depth));
  glm::vec3 a;
  for (int c = 0; c < 3; ++c)
    a[c] = float(-std::log(std::max(double(tint[c]), 1e-3)) / depth);
  return a;
}

namespace {

unsigned texture(GLenum format, int width, int height) {
  unsigned t = 0;
  glCreateTextures(GL_TEXTURE_2D, 1, &t);
  glTextureStorage2D(t, 1, format, width, height);
  glTextureParameteri(t, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  glTextureParameteri(t, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  return t;
}

void check_complete(unsigned fbo, const char* what) {
  const GLenum status = glCheckNamedFramebufferStatus(fbo, GL_FRAMEBUFFER);
  if (status != GL_FRAMEBUFFER_COMPLETE)
    throw Error(std::string("render: the water's ") + what + " framebuffer is incomplete (status " +
                std::to_string(status) + ")");
}

} // namespace

WaterLayers::WaterLayers(int width, int height)
    : width_(width), height_(height),
      resolve_(std::make_unique<ShaderProgram>("screen.vert + water_resolve.frag",
                                               shaders::kScreenVert, shaders::kWaterResolveFrag)) {
  surface_ = texture(GL_RGBA8, width, height);
  normal_ = texture(GL_RG16F, width, height);
  front_ = texture(GL_DEPTH_COMPONENT32F, width, height);
  back_ = texture(GL_DEPTH_COMPONENT32F, width, height);
  glCreateFramebuffers(1, &front_fbo_);
  glNamedFramebufferTexture(front_fbo_, GL_COLOR_ATTACHMENT0, surface_, 0);
  glNamedFramebufferTexture(front_fbo_, GL_COLOR_ATTACHMENT1, normal_, 0);
  glNamedFramebufferTexture(front_fbo_, GL_DEPTH_ATTACHMENT, front_, 0);
  const GLenum both[] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1};
  glNamedFramebufferDrawBuffers(front_fbo_, 2, both);
  glCreateFramebuffers(1, &back_fbo_);
  glNamedFramebufferTexture(back_fbo_, GL_DEPTH_ATTACHMENT, back_, 0);
  glNamedFramebufferDrawBuffer(back_fbo_, GL_NONE);
  glNamedFramebufferReadBuffer(back_fbo_, GL_NONE);
  glCreateVertexArrays(1, &vao_);
  check_complete(front_fbo_, "front layers'");
  check_complete(back_fbo_, "back faces'");
  check_gl("making the water's layers");
}

WaterLayers::~WaterLayers() {
  glDeleteFramebuffers(1, &front_fbo_);
  glDeleteFramebuffers(1, &back_fbo_);
  const unsigned textures[] = {surface_, normal_, front_, back_};
  glDeleteTextures(4, textures);
  glDeleteVertexArrays(1, &vao_);
}

void WaterLayers::begin_front() {
  glBindFramebuffer(GL_FRAMEBUFFER, front_fbo_);
  glViewport(0, 0, width_, height_);
  const float none[4] = {0, 0, 0, 0}, one = 1.0f;
  glClearNamedFramebufferfv(front_fbo_, GL_COLOR, 0, none);
  glClearNamedFramebufferfv(front_fbo_, GL_COLOR, 1, none);
  glClearNamedFramebufferfv(front_fbo_, GL_DEPTH, 0, &one);
}

void WaterLayers::begin_back() {
  glBindFramebuffer(GL_FRAMEBUFFER, back_fbo_);
  glViewport(0, 0, width_, height_);
  const float one = 1.0f;
  glClearNamedFramebufferfv(back_fbo_, GL_DEPTH, 0, &one);
}

void WaterLayers::resolve(const OffscreenTarget& opaque, const ViewMatrices& view,
                          const WaterOptics& optics, OffscreenTarget& out) {
  if (opaque.width() != width_ || opaque.height() != height_ || out.width() != width_ ||
      out.height() != height_)
    throw Error("render: the water's layers and the picture differ in size");
  out.bind();
  glDisable(GL_DEPTH_TEST);
  glDisable(GL_CULL_FACE);
  const unsigned p = resolve_->id();
  glUseProgram(p);
  glUniformMatrix4fv(glGetUniformLocation(p, "projection"), 1, GL_FALSE,
                     glm::value_ptr(view.projection));
  const glm::mat4 inverse = glm::inverse(view.projection);
  glUniformMatrix4fv(glGetUniformLocation(p, "inverse_projection"), 1, GL_FALSE,
                     glm::value_ptr(inverse));
  glUniform3fv(glGetUniformLocation(p, "absorption"), 1, glm::value_ptr(optics.absorption));
  glUniform1f(glGetUniformLocation(p, "relative_index"), 1.0f / optics.refractive_index);
  const unsigned textures[] = {
      opaque.colour_texture(), opaque.depth_texture(), surface_, normal_, front_, back_};
  glBindTextures(0, 6, textures);
  glBindVertexArray(vao_);
  glDrawArrays(GL_TRIANGLES, 0, 3);
  const unsigned none[6] = {};
  glBindTextures(0, 6, none);
  glEnable(GL_DEPTH_TEST);
  check_gl("resolving the water");
}

std::vector<WaterPixel> WaterLayers::read() const {
  const std::size_t n = std::size_t(width_) * std::size_t(height_);
  std::vector<std::uint8_t> surface(4 * n);
  std::vector<std::uint16_t> normal(2 * n);
  std::vector<float> front(n), back(n);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glGetTextureImage(surface_, 0, GL_RGBA, GL_UNSIGNED_BYTE, GLsizei(surface.size()),
                    surface.data());
  glGetTextureImage(normal_, 0, GL_RG, GL_HALF_FLOAT, GLsizei(2 * normal.size()), normal.data());
  glGetTextureImage(front_, 0, GL_DEPTH_COMPONENT, GL_FLOAT, GLsizei(4 * n), front.data());
  glGetTextureImage(back_, 0, GL_DEPTH_COMPONENT, GL_FLOAT, GLsizei(4 * n), back.data());
  check_gl("reading the water's layers");
  flip_rows(surface, 4 * std::size_t(width_));
  flip_rows(normal, 2 * std::size_t(width_));
  flip_rows(front, std::size_t(width_));
  flip_rows(back, std::size_t(width_));
  std::vector<WaterPixel> out(n);
  for (std::size_t k = 0; k < n; ++k) {
    std::memcpy(out[k].surface, &surface[4 * k], 4);
    std::memcpy(out[k].normal, &normal[2 * k], 4);
    out[k].front = front[k];
    out[k].back = back[k];
  }
  return out;
}

void WaterLayers::write(const std::vector<WaterPixel>& pixels) {
  const std::size_t n = std::size_t(width_) * std::size_t(height_);
  if (pixels.size() != n)
    throw Error("render: " + std::to_string(pixels.size()) + " water pixels for a " +
                std::to_string(width_) + " x " + std::to_string(height_) + " picture");
  std::vector<std::uint8_t> surface(4 * n);
  std::vector<std::uint16_t> normal(2 * n);
  std::vector<float> front(n), back(n);
  for (std::size_t k = 0; k < n; ++k) {
    std::memcpy(&surface[4 * k], pixels[k].surface, 4);
    std::memcpy(&normal[2 * k], pixels[k].normal, 4);
    front[k] = pixels[k].front;
    back[k] = pixels[k].back;
  }
  flip_rows(surface, 4 * std::size_t(width_));
  flip_rows(normal, 2 * std::size_t(width_));
  flip_rows(front, std::size_t(width_));
  flip_rows(back, std::size_t(width_));
  glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  glTextureSubImage2D(surface_, 0, 0, 0, width_, height_, GL_RGBA, GL_UNSIGNED_BYTE,
                      surface.data());
  glTextureSubImage2D(normal_, 0, 0, 0, width_, height_, GL_RG, GL_HALF_FLOAT, normal.data());
  glTextureSubImage2D(front_, 0, 0, 0, width_, height_, GL_DEPTH_COMPONENT, GL_FLOAT, front.data());
  glTextureSubImage2D(back_, 0, 0, 0, width_, height_, GL_DEPTH_COMPONENT, GL_FLOAT, back.data());
  check_gl("writing the water's layers");
}

} // namespace kf::render
