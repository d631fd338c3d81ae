#include "render/TubeRenderer.hpp"

#include "core/Error.hpp"
#include "render/GlBuffers.hpp"
#include "render/Shaders.hpp"

#include <epoxy/gl.h>
#include <glm/gtc/type_ptr.hpp>

#include <string>

namespace kf::render {

TubeRenderer::TubeRenderer()
    : program_(std::make_unique<ShaderProgram>("tube.vert + mesh.frag", shaders::kTubeVert,
                                               with_shadow_lookup(shaders::kMeshFrag))) {
  glCreateVertexArrays(1, &vao_); // no attributes: the vertex shader pulls its data
}

TubeRenderer::~TubeRenderer() {
  glDeleteBuffers(4, buffers_);
  glDeleteVertexArrays(1, &vao_);
}

void TubeRenderer::upload(const YarnFrames& f, int sides) {
  if (sides < 3)
    throw Error("render: a tube needs at least 3 sides");
  sides_ = sides;
  segments_ = f.drawn.size();
  if (segments_ == 0)
    return;
  const std::size_t n = f.centre_radius.size();
  if (f.r_shade.size() != n || f.b.size() != n)
    throw Error("render: yarn frames of " + std::to_string(n) + " centres, " +
                std::to_string(f.r_shade.size()) + " directions and " + std::to_string(f.b.size()) +
                " binormals");
  const void* data[4] = {f.centre_radius.data(), f.r_shade.data(), f.b.data(), f.drawn.data()};
  const std::size_t bytes[4] = {n * sizeof(glm::vec4), n * sizeof(glm::vec4), n * sizeof(glm::vec4),
                                segments_ * sizeof(std::uint32_t)};
  for (int i = 0; i < 4; ++i) {
    buffers_[i] = grown_buffer(buffers_[i], capacity_[i], bytes[i]);
    glNamedBufferSubData(buffers_[i], 0, GLsizeiptr(bytes[i]), data[i]);
  }
  check_gl("uploading the frames of " + std::to_string(n) + " yarn points");
}

void TubeRenderer::draw(const glm::vec4& colour, const ViewMatrices& view, const Lighting& light) {
  if (segments_ == 0)
    return;
  use_lit_program(program_->id(), view, light);
  const unsigned p = program_->id();
  glUniform4fv(glGetUniformLocation(p, "colour"), 1, glm::value_ptr(colour));
  glUniform1i(glGetUniformLocation(p, "reflective"), 0);
  glUniform1i(glGetUniformLocation(p, "sides"), sides_);
  for (GLuint i = 0; i < 4; ++i)
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, i, buffers_[i]);
  glBindVertexArray(vao_);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LESS);
  glDrawArrays(GL_TRIANGLES, 0, GLsizei(segments_ * 6 * std::size_t(sides_)));
  check_gl("drawing " + std::to_string(segments_) + " yarn segments as tubes");
}

} // namespace kf::render
