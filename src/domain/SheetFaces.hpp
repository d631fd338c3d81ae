#pragma once
// The knit's sheet as triangles (P8 stage 5: the tunnelling guard tests a fluid particle's step
// against them): the front and back layers' quads of every piece, each split in two, and per
// knit point the faces it belongs to (CSR), so that a particle near a point finds its faces.
#include "domain/KnitBuilder.hpp"

#include <array>
#include <cstdint>
#include <vector>

namespace kf {

struct SheetFaces {
  std::vector<std::array<std::uint32_t, 3>> faces; // knit point indices
  std::vector<std::uint32_t> offsets;              // point p's faces: ids[offsets[p], offsets[p+1])
  std::vector<std::uint32_t> ids;
};

/// The outer layers' faces (front, layer 0; back, layer 2) of every piece of the mesh: a grid's
/// (nu - 1) x (nv - 1) quads (nu x (nv - 1) for a periodic tube), a mesh piece's own quads.
SheetFaces build_sheet_faces(const KnitMesh& mesh);

} // namespace kf
