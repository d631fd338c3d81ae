#pragma once
// The fluid's surface on the GPU (P6 §3: "marching cubes over a density grid splatted from the
// particles on the GPU"): FluidSurface's field and marching cubes as OpenGL compute passes, an
// indexed mesh (a vertex a crossed grid edge, shared by the triangles around it) left in GL
// buffers that MeshRenderer draws without a trip through the host. Mesa
// llvmpipe runs the same passes on a machine without a GPU. FluidSurface's host functions are
// the reference: the same grid (surface_grid), bins and case table, and tests compare both.
#include "render/FluidSurface.hpp"
#include "render/GpuTimer.hpp"
#include "render/ShaderProgram.hpp"
#include "render/SpaceSplit.hpp"

#include <cstddef>
#include <vector>

namespace kf::render {

class SurfaceCompute {
public:
  /// Needs a current context (OpenGL 4.3+ compute).
  SurfaceCompute();
  ~SurfaceCompute();
  SurfaceCompute(const SurfaceCompute&) = delete;
  SurfaceCompute& operator=(const SurfaceCompute&) = delete;

  /// The surface of `points` (surface_field then marching_cubes, with `only` as theirs) into
  /// vertex_buffer() and index_buffer(); returns its index count (three a triangle). The grid is
  /// capped by opt.max_cells and by what one GL storage buffer may hold.
  std::size_t extract(const std::vector<glm::dvec3>& points, const SurfaceOptions& opt,
                      const Region* only = nullptr);
  /// extract in two halves: start sends the passes to the GPU and returns; finish waits for
  /// their counts (passing them again on larger lists if they overflowed) and returns the index
  /// count. The host may work, and other GL commands be sent, in between (a frame's yarns).
  void start(const std::vector<glm::dvec3>& points, const SurfaceOptions& opt,
             const Region* only = nullptr);
  std::size_t finish();
  /// Marching cubes alone over a given field (tests: the same field as the host's).
  std::size_t polygonise(const ScalarGrid& grid, const Region* only = nullptr);

  /// Marks "field" and "cubes" on `timer` after those passes (null: none).
  void time_with(GpuTimer* timer) { timer_ = timer; }

  /// The last surface's vertices (position, normal and shade 1: 7 floats each; with `only`, some
  /// no triangle uses) and its triangles' indices.
  unsigned vertex_buffer() const { return vertices_; }
  unsigned index_buffer() const { return indices_; }
  std::size_t vertex_count() const { return vertex_count_; }
  std::size_t index_count() const { return index_count_; }
  /// The last field and the last surface as a host mesh (tests).
  ScalarGrid read_field() const;
  SurfaceMesh read_mesh() const;

private:
  /// The grid's blocks of 8^3 vertices the passes visit: all, or those the points flag
  /// (blocks_program_, its uniforms set); listed in active_.
  void list_blocks(bool all, std::size_t points);
  void march_start(const Region* only);
  /// The vertex and cube passes on the lists' present capacities.
  void dispatch_march();
  /// The grid's buffers are made for the largest grid (max_cells_) the first time: a splash
  /// grows its grid from frame to frame, and each reallocation stalled a frame by 0.1-0.9 s on
  /// an H100 (the pour's film grew its grid five times at 1.5 times, twice at 4 times). The
  /// storage is only touched as far as a grid reaches.
  double headroom() const {
    const double n = double(grid_.n[0]) * grid_.n[1] * grid_.n[2];
    return n > 0 ? std::max(1.0, double(max_cells_) / n) : 1.0;
  }

  ShaderProgram blocks_program_, compact_program_, field_program_, vertex_program_, cube_program_;
  unsigned points_ = 0, bin_start_ = 0, flags_ = 0, active_ = 0, field_ = 0, first_ = 0, cases_ = 0,
           vertices_ = 0, indices_ = 0, counter_ = 0;
  std::size_t points_capacity_ = 0, bins_capacity_ = 0, flags_capacity_ = 0, active_capacity_ = 0,
              field_capacity_ = 0, first_capacity_ = 0, vertex_capacity_ = 0, index_capacity_ = 0;
  glm::ivec3 blocks_{0};
  unsigned block_groups_ = 0;
  std::size_t max_buffer_ = 0; // GL_MAX_SHADER_STORAGE_BLOCK_SIZE
  std::size_t max_cells_ = 0;  // the last options' grid cap
  ScalarGrid grid_;            // the last grid's layout (no values)
  std::size_t vertex_count_ = 0, index_count_ = 0;
  bool marching_ = false; // passes started and not yet finished
  GpuTimer* timer_ = nullptr;
};

} // namespace kf::render
