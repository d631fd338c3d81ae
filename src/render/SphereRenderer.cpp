#include "render/SphereRenderer.hpp"

#include "core/Error.hpp"
#include "render/Shaders.hpp"

#include <epoxy/gl.h>
#include <glm/gtc/type_ptr.hpp>

namespace kf::render {

SphereRenderer::SphereRenderer()
    : program_(std::make_unique<ShaderProgram>("sphere.vert + sphere.frag", shaders::kSphereVert,
                                               with_shadow_lookup(shaders::kSphereFrag))) {
  glCreateVertexArrays(1, &vao_);
  glCreateBuffers(1, &buffer_);
}

SphereRenderer::~SphereRenderer() {
  glDeleteBuffers(1, &buffer_);
  glDeleteVertexArrays(1, &vao_);
}

void SphereRenderer::draw(const std::vector<Sphere>& spheres, const ViewMatrices& view,
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
  use_lit_program(program_->id(), view, light);
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, buffer_);
  glBindVertexArray(vao_);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LESS);
  glDrawArraysInstanced(GL_TRIANGLE_STRIP, 0, 4, GLsizei(spheres.size()));
  check_gl("drawing " + std::to_string(spheres.size()) + " spheres");
}

} // namespace kf::render
