#include "render/Camera.hpp"

#include <glm/gtc/matrix_transform.hpp>

#include <algorithm>
#include <cmath>

namespace kf::render {

glm::mat4 Camera::view() const {
  return glm::mat4(glm::lookAt(eye, target, up));
}

glm::mat4 Camera::projection(double aspect) const {
  return glm::mat4(glm::perspective(glm::radians(fov_deg), aspect, near, far));
}

Camera Camera::framing(const glm::dvec3& lo, const glm::dvec3& hi, double aspect) {
  Camera c;
  c.target = 0.5 * (lo + hi);
  const double radius = std::max(0.5 * glm::length(hi - lo), 1e-6);
  // The narrower of the two fields of view must hold the sphere: sin(half angle) = r / distance.
  const double half_v = glm::radians(c.fov_deg) / 2;
  const double half = std::min(half_v, std::atan(std::tan(half_v) * aspect));
  const glm::dvec3 from = glm::normalize(glm::dvec3(0.55, -1.0, 0.6));
  // Far enough for the bounding sphere; then as close as keeps the box's 8 corners inside 95% of
  // the picture (a tall thin box, a column of water, fills it instead of a sliver of a sphere's
  // frame). Bisection: a corner's reach outward only shrinks as the camera backs away.
  auto fits = [&](double distance) {
    Camera t = c;
    t.eye = c.target + from * distance;
    t.near = distance * 1e-3;
    t.far = distance + 2 * radius;
    const glm::dmat4 m = glm::dmat4(t.projection(aspect)) * glm::dmat4(t.view());
    for (int k = 0; k < 8; ++k) {
      const glm::dvec4 p =
          m * glm::dvec4(k & 1 ? hi.x : lo.x, k & 2 ? hi.y : lo.y, k & 4 ? hi.z : lo.z, 1.0);
      if (p.w <= t.near || std::abs(p.x / p.w) > 0.95 || std::abs(p.y / p.w) > 0.95)
        return false;
    }
    return true;
  };
  double far_enough = radius / std::sin(half) * 1.05, too_close = 0.0;
  for (int k = 0; k < 40; ++k) {
    const double mid = 0.5 * (far_enough + too_close);
    (fits(mid) ? far_enough : too_close) = mid;
  }
  const double distance = far_enough;
  c.eye = c.target + from * distance;
  c.near = std::max(distance - 2 * radius, distance * 1e-3);
  c.far = distance + 2 * radius;
  return c;
}

} // namespace kf::render
