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

} // namespace kf::render
