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

namespace {

/// A texture's texels, as GL stores them (bottom row first).
template <typename T>
std::vector<T> texels(unsigned texture, GLenum format, GLenum type, std::size_t count) {
  std::vector<T> v(count);
  glGetTextureImage(texture, 0, format, type, GLsizei(v.size() * sizeof(T)), v.data());
  return v;
}

} // namespace

std::vector<LayeredPixel> WaterLayers::read(const OffscreenTarget& opaque) const {
  if (opaque.width() != width_ || opaque.height() != height_)
    throw Error("render: the water's layers and the picture differ in size");
  const std::size_t n = std::size_t(width_) * std::size_t(height_);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  const auto colour =
      texels<std::uint8_t>(opaque.colour_texture(), GL_RGBA, GL_UNSIGNED_BYTE, 4 * n);
  const auto depth = texels<float>(opaque.depth_texture(), GL_DEPTH_COMPONENT, GL_FLOAT, n);
  const auto surface = texels<std::uint8_t>(surface_, GL_RGBA, GL_UNSIGNED_BYTE, 4 * n);
  const auto normal = texels<std::uint16_t>(normal_, GL_RG, GL_HALF_FLOAT, 2 * n);
  const auto front = texels<float>(front_, GL_DEPTH_COMPONENT, GL_FLOAT, n);
  const auto back = texels<float>(back_, GL_DEPTH_COMPONENT, GL_FLOAT, n);
  check_gl("reading the water's layers");
  std::vector<LayeredPixel> out(n);
  const auto count = std::ptrdiff_t(n);
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t i = 0; i < count; ++i) {
    const auto k = std::size_t(i);
    LayeredPixel& p = out[k];
    std::memcpy(p.opaque.rgba, &colour[4 * k], 4);
    p.opaque.depth = depth[k];
    std::memcpy(p.water.surface, &surface[4 * k], 4);
    std::memcpy(p.water.normal, &normal[2 * k], 4);
    p.water.front = front[k];
    p.water.back = back[k];
  }
  return out;
}

void WaterLayers::write(const std::vector<LayeredPixel>& layers, OffscreenTarget& opaque) {
  const std::size_t n = std::size_t(width_) * std::size_t(height_);
  if (layers.size() != n || opaque.width() != width_ || opaque.height() != height_)
    throw Error("render: " + std::to_string(layers.size()) + " layered pixels for a " +
                std::to_string(width_) + " x " + std::to_string(height_) + " picture");
  std::vector<std::uint8_t> colour(4 * n), surface(4 * n);
  std::vector<std::uint16_t> normal(2 * n);
  std::vector<float> depth(n), front(n), back(n);
  const auto count = std::ptrdiff_t(n);
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t i = 0; i < count; ++i) {
    const auto k = std::size_t(i);
    const LayeredPixel& p = layers[k];
    std::memcpy(&colour[4 * k], p.opaque.rgba, 4);
    depth[k] = p.opaque.depth;
    std::memcpy(&surface[4 * k], p.water.surface, 4);
    std::memcpy(&normal[2 * k], p.water.normal, 4);
    front[k] = p.water.front;
    back[k] = p.water.back;
  }
  glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  const int w = width_, h = height_;
  glTextureSubImage2D(opaque.colour_texture(), 0, 0, 0, w, h, GL_RGBA, GL_UNSIGNED_BYTE,
                      colour.data());
  glTextureSubImage2D(opaque.depth_texture(), 0, 0, 0, w, h, GL_DEPTH_COMPONENT, GL_FLOAT,
                      depth.data());
  glTextureSubImage2D(surface_, 0, 0, 0, w, h, GL_RGBA, GL_UNSIGNED_BYTE, surface.data());
  glTextureSubImage2D(normal_, 0, 0, 0, w, h, GL_RG, GL_HALF_FLOAT, normal.data());
  glTextureSubImage2D(front_, 0, 0, 0, w, h, GL_DEPTH_COMPONENT, GL_FLOAT, front.data());
  glTextureSubImage2D(back_, 0, 0, 0, w, h, GL_DEPTH_COMPONENT, GL_FLOAT, back.data());
  check_gl("writing the water's layers");
}

} // namespace kf::render
