#pragma once
// The scene's solids as meshes for the picture (P6): boxes, planes and closed triangle meshes,
// flat-shaded (a normal a face), counter-clockwise seen from outside (a plane: from its fluid's
// side), so that a one-sided draw shows a plane only from that side.
#include "render/FluidSurface.hpp"

#include <glm/glm.hpp>

#include <array>
#include <cstdint>
#include <vector>

namespace kf::render {

/// The box [lo, hi]: 6 faces of 2 triangles, normals out.
SurfaceMesh box_mesh(const glm::dvec3& lo, const glm::dvec3& hi);
/// The faces of the box [lo, hi] marked in `faces` (x-, x+, y-, y+, z-, z+), seen from inside:
/// normals in, counter-clockwise from inside. A tank's walls: drawn one-sided, those between
/// the camera and the tank turn their backs to it and are not drawn, so the camera sees in.
SurfaceMesh box_inside(const glm::dvec3& lo, const glm::dvec3& hi,
                       const std::array<bool, 6>& faces);
/// A square of half-side `half` in the plane through `point` with unit `normal` (its front),
/// centred at the point of the plane nearest `centre`.
SurfaceMesh plane_mesh(const glm::dvec3& point, const glm::dvec3& normal, const glm::dvec3& centre,
                       double half);
/// The plane through `point` with unit `normal` (its front) where it cuts the box [lo, hi]: a
/// convex polygon of 3 to 6 corners, wound counter-clockwise seen from its front; empty where
/// the plane misses the box. A plane obstacle drawn within the domain (nothing lies outside it).
SurfaceMesh plane_in_box(const glm::dvec3& point, const glm::dvec3& normal, const glm::dvec3& lo,
                         const glm::dvec3& hi);
/// A closed triangle mesh, a face normal a triangle (its vertices repeated per triangle).
SurfaceMesh triangle_mesh(const std::vector<glm::dvec3>& vertices,
                          const std::vector<std::array<std::uint32_t, 3>>& triangles);
/// `part` added to `whole`.
void append(SurfaceMesh& whole, const SurfaceMesh& part);

} // namespace kf::render
