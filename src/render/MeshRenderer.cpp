#include "render/MeshRenderer.hpp"

#include "core/Error.hpp"
#include "render/GlBuffers.hpp"
#include "render/Shaders.hpp"

#include <epoxy/gl.h>
#include <glm/gtc/type_ptr.hpp>

#include <cstddef>
#include <cstdio>
#include <string>
#include <vector>

namespace kf::render {

MeshRenderer::MeshRenderer()
    : program_(std::make_unique<ShaderProgram>("mesh.vert + mesh.frag", shaders::kMeshVert,
                                               with_light_lookups(shaders::kMeshFrag))) {
  glCreateVertexArrays(1, &vao_);
  glCreateBuffers(1, &vertices_);
  glCreateBuffers(1, &indices_);
}

MeshRenderer::~MeshRenderer() {
  glDeleteBuffers(1, &vertices_);
  glDeleteBuffers(1, &indices_);
  glDeleteVertexArrays(1, &vao_);
}

namespace {

// Interleaved position, normal, shade.
struct Vertex {
  glm::vec3 position, normal;
  float shade;
};
static_assert(sizeof(Vertex) == 7 * sizeof(float));

void vertex_format(unsigned vao, unsigned buffer) {
  glVertexArrayVertexBuffer(vao, 0, buffer, 0, GLsizei(sizeof(Vertex)));
  const GLint components[] = {3, 3, 1};
  const GLuint offsets[] = {GLuint(offsetof(Vertex, position)), GLuint(offsetof(Vertex, normal)),
                            GLuint(offsetof(Vertex, shade))};
  for (GLuint a = 0; a < 3; ++a) {
    glEnableVertexArrayAttrib(vao, a);
    glVertexArrayAttribFormat(vao, a, components[a], GL_FLOAT, GL_FALSE, offsets[a]);
    glVertexArrayAttribBinding(vao, a, 0);
  }
}

} // namespace

void MeshRenderer::show(unsigned vertex_buffer, unsigned index_buffer, std::size_t indices) {
  indices_drawn_ = indices;
  if (indices == 0)
    return;
  vertex_format(vao_, vertex_buffer);
  glVertexArrayElementBuffer(vao_, index_buffer);
  check_gl("showing buffers of " + std::to_string(indices / 3) + " triangles");
}

void MeshRenderer::upload(const SurfaceMesh& mesh) {
  indices_drawn_ = mesh.index.size();
  if (mesh.index.empty())
    return;
  const bool shaded = !mesh.shade.empty();
  if (shaded && mesh.shade.size() != mesh.position.size())
    throw Error("render: a mesh of " + std::to_string(mesh.position.size()) + " vertices with " +
                std::to_string(mesh.shade.size()) + " shades");
  std::vector<Vertex> interleaved(mesh.position.size());
  for (std::size_t v = 0; v < mesh.position.size(); ++v)
    interleaved[v] = {mesh.position[v], mesh.normal[v], shaded ? mesh.shade[v] : 1.0f};
  const std::size_t vbytes = interleaved.size() * sizeof(Vertex);
  const std::size_t ibytes = mesh.index.size() * sizeof(std::uint32_t);
  vertices_ = grown_buffer(vertices_, vertex_capacity_, vbytes);
  indices_ = grown_buffer(indices_, index_capacity_, ibytes);
  glNamedBufferSubData(vertices_, 0, GLsizeiptr(vbytes), interleaved.data());
  glNamedBufferSubData(indices_, 0, GLsizeiptr(ibytes), mesh.index.data());
  vertex_format(vao_, vertices_);
  glVertexArrayElementBuffer(vao_, indices_);
  check_gl("uploading a mesh of " + std::to_string(mesh.triangles()) + " triangles");
}

void MeshRenderer::draw(const glm::vec4& colour, const ViewMatrices& view, const Lighting& light,
                        MeshLook look) {
  if (indices_drawn_ == 0)
    return;
  using Water = MeshLook::Water;
  if (look.water == Water::Front && !water_program_)
    water_program_ = std::make_unique<ShaderProgram>("mesh.vert + water.frag", shaders::kMeshVert,
                                                     with_light_lookups(shaders::kWaterFrag));
  if (look.water == Water::Back && !depth_program_)
    depth_program_ = std::make_unique<ShaderProgram>("mesh.vert + depth_only.frag",
                                                     shaders::kMeshVert, shaders::kDepthOnlyFrag);
  const ShaderProgram& program = look.water == Water::Front  ? *water_program_
                                 : look.water == Water::Back ? *depth_program_
                                                             : *program_;
  use_lit_program(program.id(), view, light);
  const unsigned p = program.id();
  glUniform4fv(glGetUniformLocation(p, "colour"), 1, glm::value_ptr(colour));
  glUniform1i(glGetUniformLocation(p, "reflective"), look.reflective ? 1 : 0);
  if (look.reflective && look.environment != 0) {
    glBindTextureUnit(7, look.environment);
    glUniform1i(glGetUniformLocation(p, "scene_reflected"), 1);
  }
  glBindVertexArray(vao_);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LESS);
  // The water's layers: its front faces (counter-clockwise seen from outside), or its back faces.
  if (look.one_sided || look.water != Water::None) {
    glEnable(GL_CULL_FACE);
    glCullFace(look.water == Water::Back ? GL_FRONT : GL_BACK);
  }
  glDrawElements(GL_TRIANGLES, GLsizei(indices_drawn_), GL_UNSIGNED_INT, nullptr);
  glDisable(GL_CULL_FACE);
  check_gl("drawing a mesh of " + std::to_string(indices_drawn_ / 3) + " triangles");
}

} // namespace kf::render
