#pragma once
// Wavefront OBJ geometry: the `v` and `f` records of a file, faces kept as the polygons they are
// (rigid obstacles triangulate them; quad meshes for knitted pieces will read them as quads).
// Texture coordinates, normals, groups, smoothing and materials are not geometry here and are
// skipped; so are point and line elements, which bound no surface. Anything else is an error, as
// is any malformed record: kf::Error "FILE:LINE: what is wrong".
#include "core/Vec3.hpp"

#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace kf::io {

struct ObjMesh {
  std::string source; // file name (or stand-in name) used in messages
  std::vector<Vec3d> vertices;
  // Face f has the 0-based vertex indices face_vertex[face_start[f] .. face_start[f + 1]),
  // in the file's order (>= 3 of them), and was written on line face_line[f].
  std::vector<std::uint32_t> face_start{0};
  std::vector<std::uint32_t> face_vertex;
  std::vector<int> face_line;

  std::size_t faces() const { return face_line.size(); }
  std::span<const std::uint32_t> face(std::size_t f) const {
    return {face_vertex.data() + face_start[f], face_start[f + 1] - face_start[f]};
  }
};

/// Reads an OBJ file. Throws kf::Error naming the file (and line) when it cannot be read or is
/// malformed.
ObjMesh read_obj(const std::string& path);
/// Same, from text; source_name stands in for the file name in messages.
ObjMesh parse_obj(std::string_view text, const std::string& source_name);

/// One triangle of a fan-triangulated face.
struct ObjTriangle {
  std::array<std::uint32_t, 3> v; // 0-based vertex indices, in the face's winding
  std::uint32_t face;             // the face it came from
};

/// Every face split as a fan from its first vertex ((v0, v1, v2), (v0, v2, v3), ...): exact for
/// triangles and planar convex polygons, and it keeps each face's winding.
std::vector<ObjTriangle> fan_triangles(const ObjMesh& mesh);

} // namespace kf::io
