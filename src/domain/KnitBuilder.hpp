#pragma once
// Turns the scene's knitted pieces into the three-layer rest mesh: points, masses, and the damped
// springs of paper Fig. 1a with stiffnesses derived from the fabric's moduli, so a finer mesh of
// the same fabric behaves the same. Host-only and deterministic.
#include "domain/Scene.hpp"
#include "kernels/knit/SpringTopology.hpp"
#include "kernels/knit/VolumeTopology.hpp"

#include <array>
#include <cstdint>
#include <vector>

namespace kf {

/// Where a piece's points are: point (layer, i, j) = first + layer * nu * nv + j * nu + i, with
/// i along u (wales; periodic for a tube) and j along v (courses). A mesh piece (grid = false) is
/// no grid: nu is its vertex count, nv = 1, point (layer, v) = index(layer, v, 0), and `quads`
/// holds its faces (vertex indices within one layer, in the OBJ's winding). Code that walks rows
/// and columns must skip pieces that are not grids.
struct KnitPieceLayout {
  std::uint32_t first = 0;
  int nu = 0, nv = 0;
  bool periodic_u = false;
  bool grid = true;
  std::vector<std::array<std::uint32_t, 4>> quads; // mesh pieces only
  std::uint32_t index(int layer, int i, int j) const {
    return first + static_cast<std::uint32_t>((layer * nv + j) * nu + i);
  }
};

/// What the mesh's springs and cells tell beyond their rows, over every one built (kept or not).
struct KnitMeshStats {
  double longest_stretch = 0; // the longest rest length of a stretch spring
  double stiffest = 0;        // the largest k
  double longest = 0;         // the longest rest length of any spring
  std::size_t springs = 0;
  std::vector<std::size_t> by_kind = std::vector<std::size_t>(kSpringKinds, 0);
  std::uint32_t widest = 0;       // the most springs of one point: the rows' width on every rank
  std::size_t cells = 0;          // volume cells
  std::uint32_t widest_cells = 0; // the most cells of one point (a corner of each)
};

struct KnitMesh {
  std::vector<Vec3d> x, v;           // rest position, initial velocity
  std::vector<double> m;             // dry mass [kg]
  std::vector<std::uint8_t> layer;   // 0 front, 1 middle, 2 back
  std::vector<std::uint16_t> piece;  // index into scene.knit.pieces
  std::vector<std::uint32_t> handle; // kFreePoint or the index of the pin holding the point
  std::vector<Spring> springs;
  std::vector<VolumeCell> volumes;
  std::vector<std::uint32_t> volume_index; // each kept cell's index among all the mesh's cells
  std::vector<KnitPieceLayout> pieces;
  KnitMeshStats stats;
  std::vector<std::uint32_t> spring_ends; // springs a point, during the build (then widest)
  // What the build keeps (build_knit's arguments): springs with an end flagged, cells with a
  // corner flagged (null: all; empty: none).
  const std::vector<std::uint8_t>* springs_of = nullptr;
  const std::vector<std::uint8_t>* cells_of = nullptr;
  std::vector<std::uint32_t> cell_ends; // cells a point, during the build
};

/// The scene's knit. springs_of, cells_of (a flag a point): keep only the springs with a flagged
/// end, the volume cells with a flagged corner (a rank's rows on N ranks; empty: none; the stats
/// and volume_index still count every one).
KnitMesh build_knit(const Scene& scene, const std::vector<std::uint8_t>* springs_of = nullptr,
                    const std::vector<std::uint8_t>* cells_of = nullptr);

/// Pieces shared by the grid builder and the mesh-piece builder (domain/KnitMeshPiece).
namespace knit_build {
/// Share of the through-thickness compression stiffness carried by the volume cells (the rest by
/// the straight volume springs): enough for the cells to hold the layers' order under a crush.
inline constexpr double kVolumeCellShare = 0.5;
/// Appends a spring between points i and j at their current distance (no prestress), damped at
/// `damping_ratio` of critical for the pair's reduced mass.
void add_spring(KnitMesh& mesh, std::uint32_t i, std::uint32_t j, double k, SpringKind kind,
                double damping_ratio);
/// Appends the volume cell (apex, o, a, b) at its current signed volume; `kh` is the thickness
/// stiffness [N/m] it should add at the apex, turned into k_V = kh / |dV/d apex|^2.
void add_volume_cell(KnitMesh& mesh, const std::array<std::uint32_t, 4>& point, double kh);
} // namespace knit_build

} // namespace kf
