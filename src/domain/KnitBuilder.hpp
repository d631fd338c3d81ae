#pragma once
// Turns the scene's knitted pieces into the three-layer rest mesh: points, masses, and the damped
// springs of paper Fig. 1a with stiffnesses derived from the fabric's moduli, so a finer mesh of
// the same fabric behaves the same. Host-only and deterministic.
#include "domain/Scene.hpp"
#include "kernels/knit/SpringTopology.hpp"
#include "kernels/knit/VolumeTopology.hpp"

#include <cstdint>
#include <vector>

namespace kf {

/// Where a piece's points are: point (layer, i, j) = first + layer * nu * nv + j * nu + i, with
/// i along u (wales; periodic for a tube) and j along v (courses).
struct KnitPieceLayout {
  std::uint32_t first = 0;
  int nu = 0, nv = 0;
  bool periodic_u = false;
  std::uint32_t index(int layer, int i, int j) const {
    return first + static_cast<std::uint32_t>((layer * nv + j) * nu + i);
  }
};

struct KnitMesh {
  std::vector<Vec3d> x, v;           // rest position, initial velocity
  std::vector<double> m;             // dry mass [kg]
  std::vector<std::uint8_t> layer;   // 0 front, 1 middle, 2 back
  std::vector<std::uint16_t> piece;  // index into scene.knit.pieces
  std::vector<std::uint32_t> handle; // kFreePoint or the index of the pin holding the point
  std::vector<Spring> springs;
  std::vector<VolumeCell> volumes;
  std::vector<KnitPieceLayout> pieces;
};

KnitMesh build_knit(const Scene& scene);

} // namespace kf
