// Shadows (render/ShadowMaps, P6): a ball over the floor, lit from (0.5, 0, 1). The shadow lies
// where the light's rays through the ball meet the floor: an ellipse centred at the ball's
// centre moved along the light to z = 0, semi-axes r |l| / l_z along the light's horizontal and r
// across it. Inside it the floor takes the ambient light alone, C 0.25; outside C (0.25 + 0.75
// l_z / |l|). And no shadow acne: the ball's side facing the light is what it is without shadows.
#include "render/SnapshotRender.hpp"

#include <gtest/gtest.h>

#include <cmath>

using namespace kf;

namespace {

constexpr int kW = 400, kH = 400;
const glm::dvec3 kCentre(0, 0, 0.3);
constexpr double kR = 0.1;

render::SnapshotStyle ball_over_floor(bool shadows) {
  render::SnapshotStyle s;
  s.width = kW;
  s.height = kH;
  s.shadows = shadows;
  s.floor = true;
  s.floor_z = 0;
  s.lighting.toward_light = {0.5f, 0.0f, 1.0f};
  s.lighting.ambient = 0.25f;
  s.lighting.specular = 0; // albedo only: the expected values are exact
  s.obstacles.push_back({glm::vec4(glm::vec3(kCentre), float(kR)), glm::vec4(0.5f, 0.5f, 0.5f, 1)});
  return s;
}

render::Camera from_above() {
  render::Camera c;
  c.eye = {0, 0, 2};
  c.target = {0, 0, 0};
  c.up = {0, 1, 0};
  c.fov_deg = 25;
  c.near = 0.5;
  c.far = 3;
  return c;
}

/// The red channel of the pixel showing world point p.
int red_at(const io::RgbaImage& img, const render::Camera& cam, const glm::dvec3& p) {
  const glm::dvec4 c =
      glm::dmat4(cam.projection(double(kW) / kH)) * glm::dmat4(cam.view()) * glm::dvec4(p, 1.0);
  const int col = int((c.x / c.w + 1) / 2 * kW), row = int((1 - (c.y / c.w + 1) / 2) * kH);
  return img.pixels[4 * (std::size_t(row) * kW + std::size_t(col))];
}

} // namespace

TEST(RenderShadow, TheBallsShadowLiesWhereTheLightsRaysMeetTheFloor) {
  render::SnapshotRenderer r(ball_over_floor(true));
  const render::Camera cam = from_above();
  const io::RgbaImage img = r.draw(io::Frame{}, cam);
  const glm::dvec3 l = glm::normalize(glm::dvec3(0.5, 0, 1));
  const glm::dvec3 centre = kCentre - l * (kCentre.z / l.z); // (-0.15, 0, 0)
  const double along = kR / l.z, across = kR;                // 0.112, 0.1
  const double floor_red = 0.80 * 255;
  const int lit = int(std::lround(floor_red * (0.25 + 0.75 * l.z)));
  const int dark = int(std::lround(floor_red * 0.25));
  // Well inside and well outside the ellipse (the filter softens 2 texels, ~1 mm, of its edge).
  struct Probe {
    double dx, dy;
    bool shadowed;
  };
  // (Seen from above the ball hides the floor within ~0.12 of the axis: the ellipse's side toward
  // +x is behind it.)
  for (const Probe& p :
       {Probe{0, 0, true}, Probe{-0.8 * along, 0, true}, Probe{0, 0.7 * across, true},
        Probe{0, -0.7 * across, true}, Probe{-1.3 * along, 0, false}, Probe{0, 1.3 * across, false},
        Probe{0, -1.5 * across, false}, Probe{0.3, 0.15, false}}) {
    const glm::dvec3 at = centre + glm::dvec3(p.dx, p.dy, 0);
    EXPECT_NEAR(red_at(img, cam, at), p.shadowed ? dark : lit, 2)
        << "floor at (" << at.x << ", " << at.y << ") should be " << (p.shadowed ? "in" : "out of")
        << " the shadow";
  }
}

TEST(RenderShadow, TheLitSideOfTheBallIsAsWithoutShadows) {
  render::SnapshotRenderer with(ball_over_floor(true)), without(ball_over_floor(false));
  const render::Camera cam = from_above();
  const io::RgbaImage a = with.draw(io::Frame{}, cam), b = without.draw(io::Frame{}, cam);
  const glm::dmat4 unproject =
      glm::inverse(glm::dmat4(cam.projection(double(kW) / kH)) * glm::dmat4(cam.view()));
  const glm::dvec3 l = glm::normalize(glm::dvec3(0.5, 0, 1));
  std::size_t facing = 0, differ = 0;
  for (int row = 0; row < kH; ++row)
    for (int col = 0; col < kW; ++col) {
      // The pixel's ray against the ball (a ray caster of the camera's definition).
      const double x = (col + 0.5) / kW * 2 - 1, y = 1 - (row + 0.5) / kH * 2;
      glm::dvec4 n0 = unproject * glm::dvec4(x, y, -1, 1), n1 = unproject * glm::dvec4(x, y, 1, 1);
      const glm::dvec3 o = glm::dvec3(n0) / n0.w, d = glm::normalize(glm::dvec3(n1) / n1.w - o);
      const double bq = glm::dot(d, kCentre - o),
                   disc = bq * bq - (glm::dot(kCentre - o, kCentre - o) - kR * kR);
      if (disc < 0)
        continue;
      const glm::dvec3 n = (o + d * (bq - std::sqrt(disc)) - kCentre) / kR;
      if (glm::dot(n, l) < 0.2) // near the terminator the filter may darken a little
        continue;
      ++facing;
      const std::size_t k = 4 * (std::size_t(row) * kW + std::size_t(col));
      for (int c = 0; c < 3; ++c)
        if (std::abs(int(a.pixels[k + c]) - int(b.pixels[k + c])) > 1) {
          ++differ;
          break;
        }
    }
  EXPECT_GT(facing, 2000u);
  EXPECT_EQ(differ, 0u) << "of " << facing << " pixels of the ball's lit side (shadow acne)";
}
