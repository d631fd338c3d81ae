#pragma once
// A knitted piece whose rest shape is a quad mesh from an OBJ file (free-form garments, issue P2
// item 2). The quads are checked to be a surface the three-layer model can be laid on, then each
// vertex becomes three points offset along the vertex normal, and the patch's stiffness formulas
// are applied per edge with that edge's own spacings, so a regular grid OBJ reproduces the patch
// spring for spring (tests/test_knit_mesh).
#include "core/Vec3.hpp"
#include "domain/KnitBuilder.hpp"
#include "domain/Scene.hpp"
#include "io/ObjReader.hpp"

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace kf {

/// A validated quad mesh: every face a quad, every edge in one or two faces (run in opposite
/// directions by two), every vertex in a quad and its quads one fan (a disc or a half disc).
struct KnitQuadMesh {
  std::string source;                              // the OBJ file, for messages
  std::vector<Vec3d> vertices;                     // scaled and translated
  std::vector<std::array<std::uint32_t, 4>> quads; // the OBJ's winding; its normal is the front
  std::vector<Vec3d> normals;                      // per vertex: the sum of its quads' unit normals
  // The edge neighbours of vertex v in order around it: ring[ring_start[v] .. ring_start[v+1]).
  // On the boundary (boundary[v]) the first and last are the boundary edges and quad k of the fan
  // lies between entries k and k + 1; inside, quad k lies between k and (k + 1) mod size.
  std::vector<std::uint32_t> ring_start{0}, ring;
  std::vector<std::uint8_t> boundary;
  Vec3d lo{}, hi{}; // bounding box

  std::size_t ring_size(std::size_t v) const { return ring_start[v + 1] - ring_start[v]; }
  std::uint32_t ring_at(std::size_t v, std::size_t k) const { return ring[ring_start[v] + k]; }
};

/// Maps every OBJ vertex x to scale * x + translate and checks the faces. Throws kf::Error naming
/// the mesh and what is wrong in OBJ numbering (vertices from 1, the face's line): a face that is
/// not a quad or repeats a vertex, an edge in more than two faces ("is not a manifold") or run
/// the same way by both ("is not consistently oriented"), a vertex whose quads meet only at it,
/// a vertex in no quad, a quad of zero area, a vertex whose quads' normals cancel, no faces.
KnitQuadMesh make_knit_quad_mesh(const io::ObjMesh& obj, double scale, const Vec3d& translate);

/// read_obj + make_knit_quad_mesh.
std::shared_ptr<const KnitQuadMesh> load_knit_quad_mesh(const std::string& path, double scale,
                                                        const Vec3d& translate);

/// Appends a mesh piece's points (layer by layer, OBJ vertex order), springs and volume cells to
/// `mesh` and returns its layout (grid = false). `piece.mesh` must be set.
KnitPieceLayout append_mesh_piece(const KnitPiece& piece, const Scene::Knit& mat,
                                  std::uint16_t piece_index, KnitMesh& mesh);

} // namespace kf
