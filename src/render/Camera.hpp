#pragma once
// A pinhole camera (GLM): where it stands, what it looks at, its vertical field of view.
#include <glm/glm.hpp>

namespace kf::render {

struct Camera {
  glm::dvec3 eye{1, 1, 1}, target{0, 0, 0}, up{0, 0, 1};
  double fov_deg = 35;
  double near = 0.01, far = 100;

  glm::mat4 view() const;
  glm::mat4 projection(double aspect) const;
  /// A view of the box [lo, hi] from the front, raised and to one side (z up), as close as keeps
  /// its corners inside 95% of the picture at this aspect; near and far bracket the box.
  static Camera framing(const glm::dvec3& lo, const glm::dvec3& hi, double aspect);
};

} // namespace kf::render
