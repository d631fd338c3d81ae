#include "domain/RigidShapes.hpp"

#include "core/Error.hpp"
#include "domain/MeshObstacle.hpp"

namespace kf {

template <typename T>
RigidShapes<T>::RigidShapes(const Scene& scene, exec::Backend backend) {
  for (const auto& o : scene.obstacles) {
    RigidShape<T> s;
    switch (o.shape) {
    case ObstacleShape::Plane:
      s.kind = ShapeKind::Plane;
      s.a = vec_cast<T>(o.point);
      s.b = vec_cast<T>(o.normal);
      break;
    case ObstacleShape::Box:
      s.kind = ShapeKind::Box;
      s.a = vec_cast<T>(o.min);
      s.b = vec_cast<T>(o.max);
      break;
    case ObstacleShape::Sphere:
      s.kind = ShapeKind::Sphere;
      s.a = vec_cast<T>(o.center);
      s.radius = static_cast<T>(o.radius);
      break;
    case ObstacleShape::Mesh: {
      if (!o.mesh) { // appended piecewise: GCC 12 warns (-Wrestrict) on a chain of +
        std::string msg = "obstacle '";
        msg += o.name;
        msg += "': a mesh obstacle without its geometry (the scene loader sets Obstacle::mesh; "
               "scenes built in code call load_mesh_obstacle)";
        throw Error(msg);
      }
      const SdfGrid& g = o.mesh->sdf;
      std::vector<T> values(g.values.begin(), g.values.end());
      grids_.emplace_back(backend, 0, "rigid.mesh_sdf");
      grids_.back().assign(values);
      s.kind = ShapeKind::Mesh;
      s.a = vec_cast<T>(g.origin);
      s.b = vec_cast<T>(g.far_corner());
      s.cell = static_cast<T>(g.cell);
      s.dims[0] = g.dims[0];
      s.dims[1] = g.dims[1];
      s.dims[2] = g.dims[2];
      s.sdf = grids_.back().data();
      break;
    }
    }
    s.velocity = vec_cast<T>(o.velocity);
    table_.push_back(s);
  }
  RigidShape<T> box;
  box.kind = ShapeKind::Container;
  box.a = vec_cast<T>(scene.domain.min);
  box.b = vec_cast<T>(scene.domain.max);
  box.walls = 0;
  for (int k = 0; k < 6; ++k)
    if (scene.domain.walls[k])
      box.walls |= 1u << k;
  if (box.walls)
    table_.push_back(box);
}

template <typename T>
std::size_t RigidShapes<T>::bytes() const {
  std::size_t b = 0;
  for (const auto& g : grids_)
    b += g.capacity_bytes();
  return b;
}

template class RigidShapes<float>;
template class RigidShapes<double>;

} // namespace kf
