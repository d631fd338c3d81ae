// The fluid's reflection (P6): a still pool seen at a grazing angle mirrors the sky by Fresnel's
// share. At the picture's centre the ray meets the pool at cos = 0.287 from its normal: Schlick's
// F = 0.02 + 0.98 (1 - cos)^5 = 0.201 of the sky's colour in the reflected direction (z = 0.287)
// over 0.799 of the water's own lit colour; off, the water's colour alone.
#include "render/SnapshotRender.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

using namespace kf;

namespace {

/// A still pool of particles 2 cm apart, 1 m square, two layers: its surface is flat at the
/// middle.
io::Frame pool() {
  std::vector<float> x;
  for (int i = 0; i < 50; ++i)
    for (int j = 0; j < 50; ++j)
      for (int k = 0; k < 2; ++k)
        x.insert(x.end(), {-0.5f + 0.02f * float(i), -0.5f + 0.02f * float(j), -0.02f * float(k)});
  io::Frame f;
  f.phases.push_back({"fluid", {io::Field::from("position", x, 3)}});
  return f;
}

} // namespace

TEST(RenderWater, AStillPoolMirrorsTheSkyByFresnelsShare) {
  render::SnapshotStyle s;
  s.width = 200;
  s.height = 200;
  s.lighting.toward_light = {0, 0, 1}; // overhead: the water's own colour is its albedo
  s.lighting.specular = 0;
  const glm::dvec3 albedo(0.20, 0.45, 0.85);
  s.fluid = glm::vec4(glm::vec3(albedo), 1.0f);
  render::Camera cam;
  cam.eye = {0, -0.3, 0.0}; // looking down at 16.7 degrees onto the pool's top
  cam.target = {0, 0, -0.09};
  cam.fov_deg = 20;
  cam.near = 0.05;
  cam.far = 3;
  const std::size_t centre = 4 * (100 * 200 + 100);
  const glm::dvec3 dir = glm::normalize(cam.target - cam.eye);
  for (bool on : {false, true}) {
    s.fluid_reflection = on;
    render::SnapshotRenderer r(s);
    const io::RgbaImage img = r.draw(pool(), cam);
    // Wherever the field's level lies above the top particles, the pool's middle is flat: the
    // normal there is vertical, so the angle is the ray's.
    const double cos_i = -dir.z;
    const double f = on ? 0.02 + 0.98 * std::pow(1 - cos_i, 5) : 0.0;
    const double t = std::clamp(cos_i / 0.6, 0.0, 1.0), sky_t = t * t * (3 - 2 * t);
    const glm::dvec3 sky =
        glm::mix(glm::dvec3(0.86, 0.89, 0.93), glm::dvec3(0.42, 0.58, 0.85), sky_t);
    const glm::dvec3 want = (1 - f) * albedo + f * sky;
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(img.pixels[centre + std::size_t(c)], want[c] * 255, 2.0)
          << (on ? "reflecting" : "plain") << ", channel " << c << " (F = " << f << ")";
  }
}
