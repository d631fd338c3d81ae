#include "render/SurfaceCompute.hpp"

#include "core/Error.hpp"
#include "render/GlBuffers.hpp"
#include "render/Lighting.hpp"
#include "render/Shaders.hpp"

#include <epoxy/gl.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <tuple>
#include <utility>

namespace kf::render {

namespace {

int location(unsigned program, const char* name) {
  return glGetUniformLocation(program, name);
}

GLuint groups_of_64(std::size_t n) {
  return GLuint((n + 63) / 64);
}

constexpr int kBlock = 8; // grid vertices a side of a block (active_blocks.glsl)
constexpr std::size_t kVertexBytes = 7 * sizeof(float), kIndexBytes = sizeof(GLuint);

/// A pass over the active blocks' list (shaders/active_blocks.glsl inserted).
ShaderProgram block_pass(const char* name, const char* source) {
  return ShaderProgram::compute(name, with_after_version(source, shaders::kActiveBlocksGlsl));
}

} // namespace

SurfaceCompute::SurfaceCompute()
    : blocks_program_(ShaderProgram::compute("surface_blocks.comp", shaders::kSurfaceBlocksComp)),
      compact_program_(
          ShaderProgram::compute("surface_compact.comp", shaders::kSurfaceCompactComp)),
      field_program_(block_pass("surface_field.comp", shaders::kSurfaceFieldComp)),
      vertex_program_(block_pass("surface_vertices.comp", shaders::kSurfaceVerticesComp)),
      cube_program_(block_pass("marching_cubes.comp", shaders::kMarchingCubesComp)) {
  GLint64 most = 0;
  glGetInteger64v(GL_MAX_SHADER_STORAGE_BLOCK_SIZE, &most);
  max_buffer_ = std::size_t(std::max<GLint64>(most, 1 << 27)); // the spec's least: 128 MiB
  const MarchingCubesTable& table = marching_cubes_table();
  glCreateBuffers(1, &cases_);
  glNamedBufferStorage(cases_, GLsizeiptr(table.cases.size() * sizeof(int)), table.cases.data(), 0);
  glCreateBuffers(1, &counter_);
  glNamedBufferStorage(counter_, 2 * sizeof(GLuint), nullptr, GL_DYNAMIC_STORAGE_BIT);
  const unsigned p = cube_program_.id();
  glProgramUniform1i(p, location(p, "stride"), table.stride);
  glProgramUniform1iv(p, location(p, "edge_corners"), 24, table.edge_corners.data());
  check_gl("setting up the surface's compute passes");
}

SurfaceCompute::~SurfaceCompute() {
  const unsigned buffers[] = {points_, bin_start_, flags_,    active_,  field_,
                              first_,  cases_,     vertices_, indices_, counter_};
  glDeleteBuffers(10, buffers);
}

std::size_t SurfaceCompute::extract(const std::vector<glm::dvec3>& points,
                                    const SurfaceOptions& opt, const Region* only) {
  start(points, opt, only);
  return finish();
}

void SurfaceCompute::start(const std::vector<glm::dvec3>& points, const SurfaceOptions& opt,
                           const Region* only) {
  SurfaceOptions capped = opt;
  capped.max_cells = std::min(opt.max_cells, max_buffer_ / sizeof(float));
  grid_ = surface_grid(points, capped);
  max_cells_ = capped.max_cells;
  vertex_count_ = index_count_ = 0;
  marching_ = false;
  if (points.empty())
    return;
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
  // The blocks within reach of a particle (and within a region's near box): the rest of the grid
  // keeps the empty value, which the field has there too (no particle within reach: weighted
  // -reach, naive a sum of 0 less 1/2).
  const double cell = grid_.cell;
  // With a region, the vertices marching_cubes(only) reads: within two cells of it (relative to
  // the grid's origin).
  const glm::dvec3 near_lo = only ? only->lo - 2 * cell - lo : glm::dvec3(0);
  const glm::dvec3 near_hi = only ? only->hi + 2 * cell - lo : glm::dvec3(0);
  glm::ivec3 first_vertex(0), last_vertex(grid_.n[0] - 1, grid_.n[1] - 1, grid_.n[2] - 1);
  if (only) {
    for (int a = 0; a < 3; ++a) {
      first_vertex[a] = int(std::clamp(std::ceil(near_lo[a] / cell), 0.0, double(grid_.n[a])));
      last_vertex[a] = int(std::clamp(std::floor(near_hi[a] / cell), -1.0, double(grid_.n[a] - 1)));
    }
  }
  const unsigned b = blocks_program_.id();
  glProgramUniform1ui(b, location(b, "points"), GLuint(points.size()));
  glProgramUniform1f(b, location(b, "cell"), float(cell));
  glProgramUniform1f(b, location(b, "margin"), float(reach + 2 * cell));
  glProgramUniform3i(b, location(b, "first_vertex"), first_vertex.x, first_vertex.y,
                     first_vertex.z);
  glProgramUniform3i(b, location(b, "last_vertex"), last_vertex.x, last_vertex.y, last_vertex.z);
  list_blocks(false, points.size());
  const float empty = opt.field == SurfaceField::Weighted ? float(-reach) : -0.5f;
  field_ = grown_buffer(field_, field_capacity_, total * sizeof(float), headroom());
  glClearNamedBufferSubData(field_, GL_R32F, 0, GLsizeiptr(total * sizeof(float)), GL_RED, GL_FLOAT,
                            &empty);

  const unsigned p = field_program_.id();
  glProgramUniform3i(p, location(p, "vertices"), grid_.n[0], grid_.n[1], grid_.n[2]);
  glProgramUniform1f(p, location(p, "cell"), float(cell));
  glProgramUniform3i(p, location(p, "bins"), bins.n[0], bins.n[1], bins.n[2]);
  glProgramUniform1f(p, location(p, "bin_size"), float(reach));
  glProgramUniform1f(p, location(p, "reach"), float(reach));
  glProgramUniform1f(p, location(p, "volume"), float(dp * dp * dp));
  glProgramUniform1f(p, location(p, "radius"), float(opt.radius * dp));
  glProgramUniform1i(p, location(p, "weighted"), opt.field == SurfaceField::Weighted ? 1 : 0);
  glProgramUniform1i(p, location(p, "limited"), only ? 1 : 0);
  if (only) {
    const glm::vec3 l(near_lo), h(near_hi);
    glProgramUniform3f(p, location(p, "near_lo"), l.x, l.y, l.z);
    glProgramUniform3f(p, location(p, "near_hi"), h.x, h.y, h.z);
  }
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, points_);
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, bin_start_);
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 2, field_);
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 9, active_);
  glUseProgram(p);
  glDispatchCompute(block_groups_, 1, 1);
  glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT);
  if (timer_)
    timer_->mark("field");
  check_gl("the fluid surface's field on a grid of " + std::to_string(total) + " vertices");
  march_start(only);
}

std::size_t SurfaceCompute::polygonise(const ScalarGrid& grid, const Region* only) {
  grid_ = grid;
  grid_.value.clear();
  max_cells_ = grid.value.size();
  vertex_count_ = index_count_ = 0;
  const std::size_t total = std::size_t(grid.n[0]) * grid.n[1] * grid.n[2];
  if (grid.value.size() != total)
    throw Error("render: a field of " + std::to_string(grid.value.size()) +
                " values on a grid of " + std::to_string(total) + " vertices");
  if (total == 0)
    return 0;
  field_ = grown_buffer(field_, field_capacity_, total * sizeof(float), headroom());
  glNamedBufferSubData(field_, 0, GLsizeiptr(total * sizeof(float)), grid.value.data());
  list_blocks(true, 0);
  march_start(only);
  return finish();
}

void SurfaceCompute::list_blocks(bool all, std::size_t points) {
  for (int a = 0; a < 3; ++a)
    blocks_[a] = (grid_.n[a] + kBlock - 1) / kBlock;
  const std::size_t total = std::size_t(blocks_[0]) * blocks_[1] * blocks_[2];
  flags_ = grown_buffer(flags_, flags_capacity_, total * sizeof(GLuint), headroom());
  active_ = grown_buffer(active_, active_capacity_, (total + 1) * sizeof(GLuint), headroom());
  const GLuint flag = all ? 1 : 0, zero = 0;
  glClearNamedBufferSubData(flags_, GL_R32UI, 0, GLsizeiptr(total * sizeof(GLuint)), GL_RED_INTEGER,
                            GL_UNSIGNED_INT, &flag);
  glClearNamedBufferSubData(active_, GL_R32UI, 0, sizeof(GLuint), GL_RED_INTEGER, GL_UNSIGNED_INT,
                            &zero);
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 8, flags_);
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 9, active_);
  if (!all) {
    const unsigned b = blocks_program_.id();
    glProgramUniform3i(b, location(b, "blocks"), blocks_[0], blocks_[1], blocks_[2]);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, points_);
    glUseProgram(b);
    glDispatchCompute(groups_of_64(points), 1, 1);
    glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT);
  }
  const unsigned c = compact_program_.id();
  glProgramUniform1ui(c, location(c, "total"), GLuint(total));
  glUseProgram(c);
  glDispatchCompute(groups_of_64(total), 1, 1);
  glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT);
  // The passes over the list: a work group a block, striding (a dispatch's groups are capped).
  block_groups_ = GLuint(std::min<std::size_t>(total, 65535));
  for (const unsigned p : {field_program_.id(), vertex_program_.id(), cube_program_.id()})
    glProgramUniform3i(p, location(p, "blocks"), blocks_[0], blocks_[1], blocks_[2]);
  check_gl("listing the surface grid's " + std::to_string(total) + " blocks");
}

void SurfaceCompute::march_start(const Region* only) {
  const int nx = grid_.n[0], ny = grid_.n[1], nz = grid_.n[2];
  vertex_count_ = index_count_ = 0;
  marching_ = nx >= 2 && ny >= 2 && nz >= 2;
  if (!marching_)
    return;
  const std::size_t total = std::size_t(nx) * ny * nz;
  first_ = grown_buffer(first_, first_capacity_, total * sizeof(GLuint), headroom());
  const glm::vec3 origin(grid_.origin);
  for (const unsigned p : {vertex_program_.id(), cube_program_.id()}) {
    glProgramUniform3i(p, location(p, "vertices"), nx, ny, nz);
    glProgramUniform1f(p, location(p, "cell"), float(grid_.cell));
    glProgramUniform3f(p, location(p, "origin"), origin.x, origin.y, origin.z);
  }
  const unsigned cubes = cube_program_.id();
  glProgramUniform1i(cubes, location(cubes, "limited"), only ? 1 : 0);
  if (only) {
    const glm::vec3 lo(only->lo), hi(only->hi);
    glProgramUniform3f(cubes, location(cubes, "only_lo"), lo.x, lo.y, lo.z);
    glProgramUniform3f(cubes, location(cubes, "only_hi"), hi.x, hi.y, hi.z);
  }
  if (vertices_ == 0) {
    vertices_ = grown_buffer(vertices_, vertex_capacity_, std::size_t(1) << 20);
    indices_ = grown_buffer(indices_, index_capacity_, std::size_t(1) << 20);
  }
  dispatch_march();
  if (timer_)
    timer_->mark("cubes");
}

void SurfaceCompute::dispatch_march() {
  const unsigned cubes = cube_program_.id();
  const GLuint zero[2] = {0, 0};
  glNamedBufferSubData(counter_, 0, sizeof zero, zero);
  glProgramUniform1ui(vertex_program_.id(), location(vertex_program_.id(), "capacity"),
                      GLuint(vertex_capacity_ / kVertexBytes));
  glProgramUniform1ui(cubes, location(cubes, "capacity"), GLuint(index_capacity_ / kIndexBytes));
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 2, field_);
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 3, cases_);
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 4, vertices_);
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 5, counter_);
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 6, first_);
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 7, indices_);
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 9, active_);
  glUseProgram(vertex_program_.id());
  glDispatchCompute(block_groups_, 1, 1);
  glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT);
  glUseProgram(cubes);
  glDispatchCompute(block_groups_, 1, 1);
  glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT | GL_VERTEX_ATTRIB_ARRAY_BARRIER_BIT |
                  GL_ELEMENT_ARRAY_BARRIER_BIT | GL_SHADER_STORAGE_BARRIER_BIT);
  check_gl("marching cubes over a grid of " + std::to_string(grid_.n[0]) + " x " +
           std::to_string(grid_.n[1]) + " x " + std::to_string(grid_.n[2]));
}

std::size_t SurfaceCompute::finish() {
  if (!marching_)
    return index_count_ = vertex_count_ = 0;
  marching_ = false;
  auto counts = [&] {
    GLuint written[2] = {0, 0};
    glGetNamedBufferSubData(counter_, 0, sizeof written, written);
    check_gl("reading the surface's counts");
    return std::pair<std::size_t, std::size_t>(written[0], written[1]);
  };
  auto [vertices, indices] = counts();
  if (vertices * kVertexBytes > vertex_capacity_ || indices * kIndexBytes > index_capacity_) {
    // Too many for the lists: larger ones (a quarter to spare), once more.
    const std::size_t most = max_buffer_;
    if (vertices * kVertexBytes > most || indices * kIndexBytes > most)
      throw Error("render: the fluid's surface has " + std::to_string(indices / 3) +
                  " triangles and " + std::to_string(vertices) +
                  " vertices, more than a GL buffer holds (" + std::to_string(most) +
                  " bytes); draw the fluid as spheres (--fluid spheres)");
    auto room = [&](std::size_t n, std::size_t bytes) {
      return std::min(most, (n + n / 4) * bytes);
    };
    if (vertices * kVertexBytes > vertex_capacity_)
      vertices_ = grown_buffer(vertices_, vertex_capacity_, room(vertices, kVertexBytes));
    if (indices * kIndexBytes > index_capacity_)
      indices_ = grown_buffer(indices_, index_capacity_, room(indices, kIndexBytes));
    dispatch_march();
    std::tie(vertices, indices) = counts();
  }
  vertex_count_ = vertices;
  return index_count_ = indices;
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
  std::vector<float> v(7 * vertex_count_);
  m.index.resize(index_count_);
  if (!v.empty())
    glGetNamedBufferSubData(vertices_, 0, GLsizeiptr(v.size() * sizeof(float)), v.data());
  if (!m.index.empty())
    glGetNamedBufferSubData(indices_, 0, GLsizeiptr(m.index.size() * sizeof(GLuint)),
                            m.index.data());
  check_gl("reading the surface's triangles back");
  for (std::size_t i = 0; i < vertex_count_; ++i) {
    m.position.emplace_back(v[7 * i], v[7 * i + 1], v[7 * i + 2]);
    m.normal.emplace_back(v[7 * i + 3], v[7 * i + 4], v[7 * i + 5]);
  }
  return m;
}

} // namespace kf::render
