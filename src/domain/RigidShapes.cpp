#include "domain/RigidShapes.hpp"

namespace kf {

template <typename T>
std::vector<RigidShape<T>> make_rigid_shapes(const Scene& scene) {
  std::vector<RigidShape<T>> shapes;
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
    }
    s.velocity = vec_cast<T>(o.velocity);
    shapes.push_back(s);
  }
  RigidShape<T> box;
  box.kind = ShapeKind::Container;
  box.a = vec_cast<T>(scene.domain.min);
  box.b = vec_cast<T>(scene.domain.max);
  box.walls = 0;
  for (int k = 0; k < 6; ++k)
    if (scene.domain.walls[k]) box.walls |= 1u << k;
  if (box.walls) shapes.push_back(box);
  return shapes;
}

template std::vector<RigidShape<float>> make_rigid_shapes<float>(const Scene&);
template std::vector<RigidShape<double>> make_rigid_shapes<double>(const Scene&);

} // namespace kf
