#include "domain/MeshObstacle.hpp"

#include "io/ObjReader.hpp"

#include <chrono>

namespace kf {

std::shared_ptr<const MeshObstacle> load_mesh_obstacle(const std::string& path, double scale,
                                                       const Vec3d& translate,
                                                       const SdfResolution& res) {
  auto m = std::make_shared<MeshObstacle>();
  m->solid = make_mesh_solid(io::read_obj(path), scale, translate);
  const auto t0 = std::chrono::steady_clock::now();
  m->sdf = sample_sdf(m->solid, res);
  m->build_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return m;
}

} // namespace kf
