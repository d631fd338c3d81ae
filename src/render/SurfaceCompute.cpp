#include "render/SurfaceCompute.hpp"

#include "core/Error.hpp"
#include "render/GlBuffers.hpp"
#include "render/Lighting.hpp"
#include "render/Shaders.hpp"

#include <epoxy/gl.h>

#include <algorithm>
#include <string>

namespace kf::render {

namespace {

int location(unsigned program, const char* name) {
  return glGetUniformLocation(program, name);
}

GLuint groups(int n) {
  return GLuint((n + 3) / 4);
}

} // namespace

SurfaceCompute::SurfaceCompute()
    : field_program_(ShaderProgram::compute("surface_field.comp", shaders::kSurfaceFieldComp)),
      cube_program_(ShaderProgram::compute("marching_cubes.comp", shaders::kMarchingCubesComp)) {
  GLint64 most = 0;
  glGetInteger64v(GL_MAX_SHADER_STORAGE_BLOCK_SIZE, &most);
  max_buffer_ = std::size_t(std::max<GLint64>(most, 1 << 27)); // the spec's least: 128 MiB
  const MarchingCubesTable& table = marching_cubes_table();
  glCreateBuffers(1, &cases_);
  glNamedBufferStorage(cases_, GLsizeiptr(table.cases.size() * sizeof(int)), table.cases.data(), 0);
  glCreateBuffers(1, &counter_);
  glNamedBufferStorage(counter_, sizeof(GLuint), nullptr, GL_DYNAMIC_STORAGE_BIT);
  const unsigned p = cube_program_.id();
  glProgramUniform1i(p, location(p, "stride"), table.stride);
  glProgramUniform1iv(p, location(p, "edge_corners"), 24, table.edge_corners.data());
  check_gl("setting up the surface's compute passes");
}

SurfaceCompute::~SurfaceCompute() {
  const unsigned buffers[] = {points_, bin_start_, field_, cases_, vertices_, counter_};
  glDeleteBuffers(6, buffers);
}

std::size_t SurfaceCompute::extract(const std::vector<glm::dvec3>& points,
                                    const SurfaceOptions& opt, const Region* only) {
  SurfaceOptions capped = opt;
  capped.max_cells = std::min(opt.max_cells, max_buffer_ / sizeof(float));
  grid_ = surface_grid(points, capped);
  count_ = 0;
  if (points.empty())
    return 0;
  const double dp = opt.spacing, reach = opt.support * dp;
  const glm::dvec3 lo = grid_.origin;
  const glm::dvec3 hi =
      lo + grid_.cell * glm::dvec3(grid_.n[0] - 1, grid_.n[1] - 1, grid_.n[2] - 1);
  // Binned on the host (a pass over the points: milliseconds for a million), sorted by bin so
  // a row of bins is one run of points on the GPU.
  const ParticleBins bins(points, lo, hi, reach);
  std::vector<glm::vec4> sorted(points.size());
  for (std::size_t s = 0; s < bins.item.size(); ++s)
    sorted[s] = glm::vec4(glm::vec3(points[bins.item[s]] - lo), 0.0f);
  points_ = grown_buffer(points_, points_capacity_, sorted.size() * sizeof(glm::vec4));
  bin_start_ = grown_buffer(bin_start_, bins_capacity_, bins.start.size() * sizeof(std::uint32_t));
  glNamedBufferSubData(points_, 0, GLsizeiptr(sorted.size() * sizeof(glm::vec4)), sorted.data());
  glNamedBufferSubData(bin_start_, 0, GLsizeiptr(bins.start.size() * sizeof(std::uint32_t)),
                       bins.start.data());
  const std::size_t total = std::size_t(grid_.n[0]) * grid_.n[1] * grid_.n[2];
  field_ = grown_buffer(field_, field_capacity_, total * sizeof(float));

  const unsigned p = field_program_.id();
  glProgramUniform3i(p, location(p, "vertices"), grid_.n[0], grid_.n[1], grid_.n[2]);
  glProgramUniform1f(p, location(p, "cell"), float(grid_.cell));
  glProgramUniform3i(p, location(p, "bins"), bins.n[0], bins.n[1], bins.n[2]);
  glProgramUniform1f(p, location(p, "bin_size"), float(reach));
  glProgramUniform1f(p, location(p, "reach"), float(reach));
  glProgramUniform1f(p, location(p, "volume"), float(dp * dp * dp));
  glProgramUniform1f(p, location(p, "radius"), float(opt.radius * dp));
  glProgramUniform1i(p, location(p, "weighted"), opt.field == SurfaceField::Weighted ? 1 : 0);
  glProgramUniform1i(p, location(p, "limited"), only ? 1 : 0);
  if (only) { // the vertices marching_cubes(only) reads: within two cells of the region
    const glm::vec3 near_lo(only->lo - 2 * grid_.cell - lo),
        near_hi(only->hi + 2 * grid_.cell - lo);
    glProgramUniform3f(p, location(p, "near_lo"), near_lo.x, near_lo.y, near_lo.z);
    glProgramUniform3f(p, location(p, "near_hi"), near_hi.x, near_hi.y, near_hi.z);
  }
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, points_);
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, bin_start_);
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 2, field_);
  glUseProgram(p);
  glDispatchCompute(groups(grid_.n[0]), groups(grid_.n[1]), groups(grid_.n[2]));
  glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT);
  if (timer_)
    timer_->mark("field");
  check_gl("the fluid surface's field on a grid of " + std::to_string(total) + " vertices");
  return march(only);
}

std::size_t SurfaceCompute::polygonise(const ScalarGrid& grid, const Region* only) {
  grid_ = grid;
  grid_.value.clear();
  count_ = 0;
  const std::size_t total = std::size_t(grid.n[0]) * grid.n[1] * grid.n[2];
  if (grid.value.size() != total)
    throw Error("render: a field of " + std::to_string(grid.value.size()) +
                " values on a grid of " + std::to_string(total) + " vertices");
  if (total == 0)
    return 0;
  field_ = grown_buffer(field_, field_capacity_, total * sizeof(float));
  glNamedBufferSubData(field_, 0, GLsizeiptr(total * sizeof(float)), grid.value.data());
  return march(only);
}

std::size_t SurfaceCompute::march(const Region* only) {
  const int nx = grid_.n[0], ny = grid_.n[1], nz = grid_.n[2];
  if (nx < 2 || ny < 2 || nz < 2)
    return count_ = 0;
  const unsigned p = cube_program_.id();
  glProgramUniform3i(p, location(p, "vertices"), nx, ny, nz);
  glProgramUniform1f(p, location(p, "cell"), float(grid_.cell));
  const glm::vec3 origin(grid_.origin);
  glProgramUniform3f(p, location(p, "origin"), origin.x, origin.y, origin.z);
  glProgramUniform1i(p, location(p, "limited"), only ? 1 : 0);
  if (only) {
    const glm::vec3 lo(only->lo), hi(only->hi);
    glProgramUniform3f(p, location(p, "only_lo"), lo.x, lo.y, lo.z);
    glProgramUniform3f(p, location(p, "only_hi"), hi.x, hi.y, hi.z);
  }
  constexpr std::size_t kVertexBytes = 7 * sizeof(float);
  const std::size_t most = max_buffer_ / kVertexBytes;
  auto run = [&] {
    const GLuint zero = 0;
    glNamedBufferSubData(counter_, 0, sizeof(GLuint), &zero);
    glProgramUniform1ui(p, location(p, "capacity"), GLuint(vertex_capacity_ / kVertexBytes));
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 2, field_);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 3, cases_);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 4, vertices_);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 5, counter_);
    glUseProgram(p);
    glDispatchCompute(groups(nx - 1), groups(ny - 1), groups(nz - 1));
    glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT | GL_VERTEX_ATTRIB_ARRAY_BARRIER_BIT |
                    GL_SHADER_STORAGE_BARRIER_BIT);
    GLuint written = 0;
    glGetNamedBufferSubData(counter_, 0, sizeof(GLuint), &written);
    check_gl("marching cubes over a grid of " + std::to_string(nx) + " x " + std::to_string(ny) +
             " x " + std::to_string(nz));
    return std::size_t(written);
  };
  if (vertices_ == 0)
    vertices_ = grown_buffer(vertices_, vertex_capacity_, std::size_t(1) << 20);
  std::size_t written = run();
  if (written * kVertexBytes > vertex_capacity_) { // too many: a larger list, once more
    if (written > most)
      throw Error("render: the fluid's surface has " + std::to_string(written / 3) +
                  " triangles, more than one GL buffer holds (" + std::to_string(most / 3) +
                  "); draw the fluid as spheres (--fluid spheres)");
    vertices_ = grown_buffer(vertices_, vertex_capacity_,
                             std::min(most, written + written / 4) * kVertexBytes);
    written = run();
  }
  if (timer_)
    timer_->mark("cubes");
  return count_ = written;
}

ScalarGrid SurfaceCompute::read_field() const {
  ScalarGrid g = grid_;
  g.value.resize(std::size_t(g.n[0]) * g.n[1] * g.n[2]);
  if (!g.value.empty())
    glGetNamedBufferSubData(field_, 0, GLsizeiptr(g.value.size() * sizeof(float)), g.value.data());
  check_gl("reading the surface's field back");
  return g;
}

SurfaceMesh SurfaceCompute::read_mesh() const {
  SurfaceMesh m;
  std::vector<float> v(7 * count_);
  if (!v.empty())
    glGetNamedBufferSubData(vertices_, 0, GLsizeiptr(v.size() * sizeof(float)), v.data());
  check_gl("reading the surface's triangles back");
  for (std::size_t i = 0; i < count_; ++i) {
    m.position.emplace_back(v[7 * i], v[7 * i + 1], v[7 * i + 2]);
    m.normal.emplace_back(v[7 * i + 3], v[7 * i + 4], v[7 * i + 5]);
    m.index.push_back(std::uint32_t(i));
  }
  return m;
}

} // namespace kf::render
