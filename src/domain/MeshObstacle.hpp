#pragma once
// A mesh obstacle's geometry, built once when the scene is loaded: the validated closed mesh and
// its sampled signed distance. Shared (immutable) by every copy of the scene, so `plan`, the
// samplers and the simulation in either precision and on either backend use the same samples.
#include "domain/MeshSdf.hpp"
#include "domain/MeshSolid.hpp"

#include <memory>
#include <string>

namespace kf {

struct MeshObstacle {
  MeshSolid solid;
  SdfGrid sdf;
  double build_seconds = 0; // time to sample the signed distance
};

/// Reads the OBJ file, scales and translates it, checks that it bounds a solid and samples its
/// signed distance. Throws kf::Error naming the file (and line, or edge) on any problem.
std::shared_ptr<const MeshObstacle> load_mesh_obstacle(const std::string& path, double scale,
                                                       const Vec3d& translate,
                                                       const SdfResolution& res = {});

} // namespace kf
