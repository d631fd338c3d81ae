#include "render/TubeRenderer.hpp"

#include "core/Error.hpp"
#include "render/GlBuffers.hpp"
#include "render/RegionClip.hpp"
#include "render/Shaders.hpp"

#include <epoxy/gl.h>
#include <glm/gtc/type_ptr.hpp>

#include <string>
#include <vector>

namespace kf::render {

TubeRenderer::TubeRenderer()
    : program_(std::make_unique<ShaderProgram>("tube.vert + mesh.frag",
                                               with_region_clip(shaders::kTubeVert),
                                               with_light_lookups(shaders::kMeshFrag))),
      index_program_(ShaderProgram::compute("tube_indices.comp", shaders::kTubeIndicesComp)),
      frame_program_(ShaderProgram::compute("yarn_frames.comp", shaders::kYarnFramesComp)) {
  glCreateVertexArrays(1, &vao_); // no attributes: the vertex shader pulls its data
}

TubeRenderer::~TubeRenderer() {
  glDeleteBuffers(9, buffers_);
  glDeleteVertexArrays(1, &vao_);
}

void TubeRenderer::upload(const YarnFrames& f, int sides) {
  if (sides < 3)
    throw Error("render: a tube needs at least 3 sides");
  sides_ = sides;
  coloured_ = false;
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
  make_indices(sides);
  check_gl("uploading the frames of " + std::to_string(n) + " yarn points");
}

void TubeRenderer::make_indices(int sides) {
  // The index lists, built where they are used: every ring vertex, and every other (coarse).
  const unsigned p = index_program_.id();
  glProgramUniform1ui(p, glGetUniformLocation(p, "segments"), GLuint(segments_));
  glProgramUniform1ui(p, glGetUniformLocation(p, "sides"), GLuint(sides));
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 3, buffers_[3]);
  glUseProgram(p);
  for (int step = 1; step <= 2; ++step) {
    if (step == 2 && sides % 2 != 0)
      break;
    const std::size_t indices = segments_ * 6 * std::size_t(sides / step);
    const int i = 3 + step;
    buffers_[i] = grown_buffer(buffers_[i], capacity_[i], indices * sizeof(std::uint32_t));
    glProgramUniform1ui(p, glGetUniformLocation(p, "step"), GLuint(step));
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 4, buffers_[i]);
    glDispatchCompute(GLuint((segments_ + 63) / 64), 1, 1);
  }
  glMemoryBarrier(GL_ELEMENT_ARRAY_BARRIER_BIT);
}

void TubeRenderer::build(const YarnPoints& y, const YarnStyle& style, const Region* only,
                         double reach) {
  if (!(style.radius > 0) || style.sides < 3)
    throw Error("render: a yarn needs a radius > 0 and at least 3 sides");
  const YarnChains chains = yarn_chains(y, only, reach);
  sides_ = style.sides;
  segments_ = chains.drawn.size();
  coloured_ = false;
  if (segments_ == 0)
    return;
  const std::size_t n = y.point.size();
  if (!y.colour.empty()) {
    if (y.colour.size() != n)
      throw Error("render: " + std::to_string(y.colour.size()) + " yarn colours for " +
                  std::to_string(n) + " points");
    buffers_[8] = grown_buffer(buffers_[8], capacity_[8], n * sizeof(glm::vec4));
    glNamedBufferSubData(buffers_[8], 0, GLsizeiptr(n * sizeof(glm::vec4)), y.colour.data());
    coloured_ = true;
  }
  const void* data[3] = {y.point.data(), chains.start.data(), chains.drawn.data()};
  const std::size_t bytes[3] = {n * sizeof(glm::vec4), chains.start.size() * sizeof(std::uint32_t),
                                segments_ * sizeof(std::uint32_t)};
  const int slot[3] = {6, 7, 3};
  for (int k = 0; k < 3; ++k) {
    const int i = slot[k];
    buffers_[i] = grown_buffer(buffers_[i], capacity_[i], bytes[k]);
    glNamedBufferSubData(buffers_[i], 0, GLsizeiptr(bytes[k]), data[k]);
  }
  for (int i = 0; i < 3; ++i) {
    buffers_[i] = grown_buffer(buffers_[i], capacity_[i], n * sizeof(glm::vec4));
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, GLuint(i), buffers_[i]);
  }
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 5, buffers_[6]);
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 6, buffers_[7]);
  const unsigned p = frame_program_.id();
  const GLuint chain_count = GLuint(chains.start.size() - 1);
  glProgramUniform1ui(p, glGetUniformLocation(p, "chains"), chain_count);
  glProgramUniform1f(p, glGetUniformLocation(p, "radius"), float(style.radius));
  glProgramUniform1f(p, glGetUniformLocation(p, "swell"), float(style.swell));
  glProgramUniform1f(p, glGetUniformLocation(p, "darkening"), float(style.wet_darkening));
  glUseProgram(p);
  glDispatchCompute((chain_count + 63) / 64, 1, 1);
  glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT);
  make_indices(sides_);
  check_gl("the frames of " + std::to_string(n) + " yarn points");
}

void TubeRenderer::draw(const glm::vec4& colour, const ViewMatrices& view, const Lighting& light,
                        bool coarse, bool one_sided, const Region* clip) {
  if (segments_ == 0)
    return;
  use_lit_program(program_->id(), view, light);
  const unsigned p = program_->id();
  glUniform4fv(glGetUniformLocation(p, "colour"), 1, glm::value_ptr(colour));
  glUniform1i(glGetUniformLocation(p, "reflective"), 0);
  glUniform1i(glGetUniformLocation(p, "sides"), sides_);
  glUniform1i(glGetUniformLocation(p, "coloured"), coloured_ ? 1 : 0);
  if (coloured_)
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 13, buffers_[8]);
  for (GLuint i = 0; i < 3; ++i)
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, i, buffers_[i]);
  const int step = coarse && sides_ % 2 == 0 ? 2 : 1;
  glVertexArrayElementBuffer(vao_, buffers_[3 + step]);
  glBindVertexArray(vao_);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LESS);
  if (one_sided) {
    glEnable(GL_CULL_FACE);
    glCullFace(GL_BACK);
  }
  clip_to(p, clip);
  glDrawElements(GL_TRIANGLES, GLsizei(segments_ * 6 * std::size_t(sides_ / step)), GL_UNSIGNED_INT,
                 nullptr);
  clip_to(p, nullptr);
  glDisable(GL_CULL_FACE);
  check_gl("drawing " + std::to_string(segments_) + " yarn segments as tubes");
}

} // namespace kf::render
