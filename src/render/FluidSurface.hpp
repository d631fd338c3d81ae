#pragma once
// The fluid's surface from its particles (paper §6.2): a scalar field on a fine uniform grid,
// splatted from the particles, polygonised by marching cubes into a closed, consistently oriented
// triangle mesh with smooth normals (the field's gradient). Two fields:
//   naive     the particles' volume fraction, sum_j V_j W(x - x_j) with a cubic-spline W of
//             support 2 dp (1 inside the fluid); the surface at 0.5. On a disordered free
//             surface every particle's bump shows.
//   weighted  the paper's improvement after its ref. [26] (Zhu & Bridson 2005): the distance to
//             a kernel-weighted mean of the particles nearby, r - |x - xbar(x)|: particles near
//             the surface pull the mean inward, so a flat layer gives a flat surface, and a lone
//             drop keeps a sphere of radius r.
// Host code (OpenMP over the grid); the cell is a fraction of the particles' spacing.
#include "render/SpaceSplit.hpp"

#include <glm/glm.hpp>

#include <optional>
#include <utility>

#include <algorithm>
#include <array>
#include <cstdint>
#include <vector>

namespace kf::render {

struct SurfaceMesh {
  std::vector<glm::vec3> position, normal; // a vertex each (normals unit, out of the fluid)
  std::vector<std::uint32_t> index;        // three a triangle, counter-clockwise seen from outside
  std::vector<float> shade; // a vertex, scaling the colour (a wet yarn's darkening); empty: 1
  std::size_t triangles() const { return index.size() / 3; }
  double area() const;
};

enum class SurfaceField { Naive, Weighted };

struct SurfaceOptions {
  SurfaceField field = SurfaceField::Weighted;
  double spacing = 0; // the particles' spacing dp (required, > 0)
  double cell = 0.5;  // grid cell over dp
  // Weighted: r over dp and the kernel's support over dp. Chosen on a jittered pool and a ball
  // (tests/test_render_surface): support 4, r = 1 gives normals within 2.7 degrees of vertical
  // and the ball's area within 2.6%; support 3, r = 0.75 reached 4.5 degrees.
  double radius = 1.0;
  double support = 4.0;
  std::size_t max_cells = 64u << 20; // a larger box is polygonised on a coarser grid
  // The box of the points the grid is laid over, when they are a part of them (a rank's share
  // of a frame): the grid is then the whole frame's, vertex for vertex.
  std::optional<std::pair<glm::dvec3, glm::dvec3>> box;
};

/// A regular grid of field values at its vertices: origin, cell edge, vertices per axis.
struct ScalarGrid {
  glm::dvec3 origin{0};
  double cell = 0;
  std::array<int, 3> n{0, 0, 0};
  std::vector<float> value; // positive inside the fluid, the surface at 0
  float at(int i, int j, int k) const {
    return value[std::size_t(i) +
                 std::size_t(n[0]) * (std::size_t(j) + std::size_t(n[1]) * std::size_t(k))];
  }
};

/// The grid surface_field fills for `points` (origin, cell and vertex counts; no values): their
/// box grown by the kernel's reach and a spacing, the cell opt.cell dp, coarser (x 1.25 at a time)
/// past opt.max_cells vertices. Throws a kf::Error on a non-positive spacing, cell or support.
ScalarGrid surface_grid(const std::vector<glm::dvec3>& points, const SurfaceOptions& opt);

/// Points binned in cubes of `size` from `lo` (points past the bins fall into the outer ones):
/// point item[s] for s in [start[b], start[b+1]) lies in bin b = i + n0 (j + n1 k).
struct ParticleBins {
  glm::dvec3 lo{0};
  double size = 0;
  std::array<int, 3> n{1, 1, 1};
  std::vector<std::uint32_t> start, item;

  ParticleBins(const std::vector<glm::dvec3>& p, glm::dvec3 lo, glm::dvec3 hi, double size);
  std::array<int, 3> cell_of(const glm::dvec3& x) const;
  std::size_t index(const std::array<int, 3>& c) const {
    return std::size_t(c[0]) +
           std::size_t(n[0]) * (std::size_t(c[1]) + std::size_t(n[1]) * std::size_t(c[2]));
  }
  /// f(point) for every point in the 27 bins around x's.
  template <typename F>
  void around(const glm::dvec3& x, F&& f) const {
    const auto c = cell_of(x);
    for (int k = std::max(0, c[2] - 1); k <= std::min(n[2] - 1, c[2] + 1); ++k)
      for (int j = std::max(0, c[1] - 1); j <= std::min(n[1] - 1, c[1] + 1); ++j)
        for (int i = std::max(0, c[0] - 1); i <= std::min(n[0] - 1, c[0] + 1); ++i) {
          const std::size_t b = index({i, j, k});
          for (std::uint32_t s = start[b]; s < start[b + 1]; ++s)
            f(item[s]);
        }
  }
};

/// The field of `points` on a grid covering them with a margin of the kernel's support, shifted
/// so the surface is its zero level.
/// With `only`, the values are computed within two cells of it alone (what marching_cubes(grid,
/// only) reads, normals included), the same there as without it; elsewhere the grid says outside.
ScalarGrid surface_field(const std::vector<glm::dvec3>& points, const SurfaceOptions& opt,
                         const Region* only = nullptr);

/// Marching cubes over the grid's cells: the zero level of `grid` (positive inside). The case
/// table is built from the cube's faces (each run of inside corners on a face cut off by one
/// segment, the segments chained into loops, a loop fanned into triangles): a face's ambiguous
/// case is decided by its four corners alone, the same in both cubes sharing it, so the surface
/// is closed wherever the grid's border lies outside the fluid.
/// With `only`, just the cells whose centres lie in it (sort-last rendering: the parts of every
/// rank together are the whole mesh, each triangle once).
SurfaceMesh marching_cubes(const ScalarGrid& grid, const Region* only = nullptr);

/// marching_cubes' case table, flat for a GPU: case m's triangles at m * stride, a count first,
/// then three cube edges (0-11) a triangle; edge e joins corners edge_corners[2e], [2e+1]
/// (corner bit b = x | y << 1 | z << 2).
struct MarchingCubesTable {
  int stride = 0;
  std::vector<int> cases; // 256 * stride
  std::array<int, 24> edge_corners{};
};
const MarchingCubesTable& marching_cubes_table();

} // namespace kf::render
