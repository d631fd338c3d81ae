#include "render/EnvironmentMap.hpp"

#include "core/Error.hpp"

#include <epoxy/gl.h>
#include <glm/gtc/matrix_transform.hpp>

#include <string>

namespace kf::render {

EnvironmentMap::EnvironmentMap(int size) : size_(size) {
  if (size < 1 || size > 4096)
    throw Error("render: an environment map of " + std::to_string(size) + " texels a side");
  glCreateTextures(GL_TEXTURE_CUBE_MAP, 1, &cube_);
  glTextureStorage2D(cube_, 1, GL_RGBA8, size, size);
  glTextureParameteri(cube_, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
  glTextureParameteri(cube_, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glTextureParameteri(cube_, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glTextureParameteri(cube_, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  glCreateRenderbuffers(1, &depth_);
  glNamedRenderbufferStorage(depth_, GL_DEPTH_COMPONENT32F, size, size);
  glCreateFramebuffers(1, &fbo_);
  glNamedFramebufferRenderbuffer(fbo_, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, depth_);
  check_gl("making an environment map");
}

EnvironmentMap::~EnvironmentMap() {
  glDeleteFramebuffers(1, &fbo_);
  glDeleteRenderbuffers(1, &depth_);
  glDeleteTextures(1, &cube_);
}

ViewMatrices EnvironmentMap::face_view(int k, const glm::dvec3& centre, double near, double far) {
  // Face k looks along its axis; its up is the table's -t direction, so that the picture's
  // x runs with s and its bottom row (row 0 in GL's framebuffer) is t = 0.
  static const glm::dvec3 axis[6] = {{1, 0, 0},  {-1, 0, 0}, {0, 1, 0},
                                     {0, -1, 0}, {0, 0, 1},  {0, 0, -1}};
  static const glm::dvec3 up[6] = {{0, -1, 0}, {0, -1, 0}, {0, 0, 1},
                                   {0, 0, -1}, {0, -1, 0}, {0, -1, 0}};
  ViewMatrices v;
  v.view = glm::mat4(glm::lookAt(centre, centre + axis[k], up[k]));
  v.projection = glm::mat4(glm::perspective(glm::radians(90.0), 1.0, near, far));
  return v;
}

void EnvironmentMap::render(const glm::dvec3& centre, double near, double far,
                            const std::function<void(const ViewMatrices&)>& draw) {
  glBindFramebuffer(GL_FRAMEBUFFER, fbo_);
  glViewport(0, 0, size_, size_);
  for (int k = 0; k < 6; ++k) {
    glNamedFramebufferTextureLayer(fbo_, GL_COLOR_ATTACHMENT0, cube_, 0, k);
    const GLenum status = glCheckNamedFramebufferStatus(fbo_, GL_FRAMEBUFFER);
    if (status != GL_FRAMEBUFFER_COMPLETE)
      throw Error("render: the environment map's face " + std::to_string(k) +
                  " is incomplete (status " + std::to_string(status) + ")");
    const float nothing[4] = {0, 0, 0, 0}, one = 1.0f;
    glClearNamedFramebufferfv(fbo_, GL_COLOR, 0, nothing);
    glClearNamedFramebufferfv(fbo_, GL_DEPTH, 0, &one);
    draw(face_view(k, centre, near, far));
  }
  check_gl("drawing the environment map");
}

std::vector<std::uint8_t> EnvironmentMap::read_face(int k) const {
  std::vector<std::uint8_t> px(std::size_t(size_) * std::size_t(size_) * 4);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glGetTextureSubImage(cube_, 0, 0, 0, k, size_, size_, 1, GL_RGBA, GL_UNSIGNED_BYTE,
                       GLsizei(px.size()), px.data());
  check_gl("reading an environment map's face");
  return px;
}

} // namespace kf::render
