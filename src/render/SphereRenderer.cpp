#include "render/SphereRenderer.hpp"

#include "core/Error.hpp"
#include "render/Shaders.hpp"

#include <epoxy/gl.h>
#include <glm/gtc/type_ptr.hpp>

namespace kf::render {

SphereRenderer::SphereRenderer()
    : program_(std::make_unique<ShaderProgram>("sphere.vert + sphere.frag", shaders::kSphereVert,
                                               shaders::kSphereFrag)) {
  glCreateVertexArrays(1, &vao_);
  glCreateBuffers(1, &buffer_);
}

SphereRenderer::~SphereRenderer() {
  glDeleteBuffers(1, &buffer_);
  glDeleteVertexArrays(1, &vao_);
}

void SphereRenderer::draw(const std::vector<Sphere>& spheres, const Camera& camera, double aspect,
                          const Lighting& light) {
  if (spheres.empty())
    return;
  const std::size_t bytes = spheres.size() * sizeof(Sphere);
  if (bytes > capacity_) { // storage grows, never shrinks, so a film reuses one buffer
    glDeleteBuffers(1, &buffer_);
    glCreateBuffers(1, &buffer_);
    glNamedBufferStorage(buffer_, GLsizeiptr(bytes), nullptr, GL_DYNAMIC_STORAGE_BIT);
    capacity_ = bytes;
  }
  glNamedBufferSubData(buffer_, 0, GLsizeiptr(bytes), spheres.data());
  const glm::mat4 view = camera.view(), proj = camera.projection(aspect);
  const glm::vec3 light_view =
      glm::normalize(glm::vec3(view * glm::vec4(light.toward_light, 0.0f)));
  program_->use();
  const unsigned p = program_->id();
  glUniformMatrix4fv(glGetUniformLocation(p, "view"), 1, GL_FALSE, glm::value_ptr(view));
  glUniformMatrix4fv(glGetUniformLocation(p, "projection"), 1, GL_FALSE, glm::value_ptr(proj));
  glUniform3fv(glGetUniformLocation(p, "light_view"), 1, glm::value_ptr(light_view));
  glUniform1f(glGetUniformLocation(p, "ambient"), light.ambient);
  glUniform1f(glGetUniformLocation(p, "specular_strength"), light.specular);
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, buffer_);
  glBindVertexArray(vao_);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LESS);
  glDrawArraysInstanced(GL_TRIANGLE_STRIP, 0, 4, GLsizei(spheres.size()));
  const GLenum err = glGetError();
  if (err != GL_NO_ERROR)
    throw Error("render: drawing " + std::to_string(spheres.size()) +
                " spheres failed (GL error 0x" +
                [&] {
                  char b[16];
                  std::snprintf(b, sizeof b, "%04x", err);
                  return std::string(b);
                }() +
                ")");
}

} // namespace kf::render
