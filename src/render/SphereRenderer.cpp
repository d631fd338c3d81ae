#include "render/SphereRenderer.hpp"

#include "core/Error.hpp"
#include "render/GlBuffers.hpp"
#include "render/Shaders.hpp"

#include <epoxy/gl.h>
#include <glm/gtc/type_ptr.hpp>

namespace kf::render {

SphereRenderer::SphereRenderer()
    : program_(std::make_unique<ShaderProgram>("sphere.vert + sphere.frag", shaders::kSphereVert,
                                               with_light_lookups(shaders::kSphereFrag))) {
  glCreateVertexArrays(1, &vao_);
}

SphereRenderer::~SphereRenderer() {
  glDeleteBuffers(1, &buffer_);
  glDeleteVertexArrays(1, &vao_);
}

void SphereRenderer::upload(const std::vector<Sphere>& spheres) {
  count_ = spheres.size();
  if (spheres.empty())
    return;
  const std::size_t bytes = spheres.size() * sizeof(Sphere);
  buffer_ = grown_buffer(buffer_, capacity_, bytes);
  glNamedBufferSubData(buffer_, 0, GLsizeiptr(bytes), spheres.data());
}

void SphereRenderer::draw(const ViewMatrices& view, const Lighting& light) {
  if (count_ == 0)
    return;
  use_lit_program(program_->id(), view, light);
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, buffer_);
  glBindVertexArray(vao_);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LESS);
  glDrawArraysInstanced(GL_TRIANGLE_STRIP, 0, 4, GLsizei(count_));
  check_gl("drawing " + std::to_string(count_) + " spheres");
}

} // namespace kf::render
