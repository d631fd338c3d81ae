#pragma once
// A triangle mesh that bounds a solid: closed (every edge shared by exactly two triangles) and
// consistently oriented (the two run the edge in opposite directions), wound outward. Only such a
// mesh has a well-defined inside, which the signed distance of a mesh obstacle needs.
#include "core/Vec3.hpp"
#include "io/ObjReader.hpp"

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace kf {

struct MeshSolid {
  std::string source;                                  // the OBJ file, for messages
  std::vector<Vec3d> vertices;                         // scaled and translated
  std::vector<std::array<std::uint32_t, 3>> triangles; // counter-clockwise seen from outside
  double volume = 0;                                   // enclosed volume [m^3]
  Vec3d lo{}, hi{};                                    // bounding box
};

/// Fan-triangulates the OBJ faces, maps every vertex x to scale * x + translate and checks that
/// the triangles bound a solid. A mesh wound inward as a whole is turned outward. Throws
/// kf::Error, naming the mesh and the offending edge in OBJ vertex numbers (from 1) and the
/// lines of its faces, when an edge belongs to one face ("is not closed"), to more than two
/// ("is not a manifold"), runs the same way in both its faces ("is not consistently oriented"),
/// when a face repeats a vertex, or when the mesh encloses no volume. Self-intersections are not
/// detected.
MeshSolid make_mesh_solid(const io::ObjMesh& obj, double scale, const Vec3d& translate);

} // namespace kf
