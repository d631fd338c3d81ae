#pragma once
// Geometric checks on a knit's positions, independent of the solver: do sheets pass through each
// other (crossings of a strip's profile), do the three layers keep their order through the
// thickness. Grid pieces (patch, tube) only: both throw std::invalid_argument on a mesh piece.
#include "core/Vec3.hpp"
#include "domain/KnitBuilder.hpp"
#include "domain/Scene.hpp"

#include <cstddef>
#include <string>
#include <vector>

namespace kf::test {

/// Proper crossings between the profiles of a strip folding in the plane spanned by `a` and `b`:
/// for every wale column i, the three layers' polylines along the courses (j), projected onto
/// (a, b), and every pair of their segments at least min_course_gap courses apart. With a gap of
/// 2 it counts the sheet passing through itself (a fold crossing a fold); a gap of 0 also counts
/// the layers of one spot shearing across each other.
std::size_t profile_crossings(const std::vector<Vec3d>& x, const KnitPieceLayout& L, Vec3d a,
                              Vec3d b, int min_course_gap = 2);

/// Nodes whose front and back layers swapped sides: the sign of (front - back) . n, with n the
/// middle layer's normal from its neighbours, differs from the rest mesh's. Interior nodes only.
std::size_t layer_order_violations(const std::vector<Vec3d>& x, const std::vector<Vec3d>& rest,
                                   const KnitPieceLayout& L);

/// A knit-only scene in double precision, a 4 m box around the origin, no output; pieces to add.
Scene knit_only_scene(const std::string& name);

/// Positions of a snapshot field (x0 y0 z0 x1 ...) as vectors.
std::vector<Vec3d> as_points(const std::vector<double>& flat);
std::vector<Vec3d> as_points(const std::vector<float>& flat);

} // namespace kf::test
