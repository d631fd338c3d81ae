// The translucent water (P6, render/WaterLayers): a slab of water over a floor of two colours,
// seen obliquely. Each pixel's ray, traced here from the camera's definition, meets the slab's
// top, refracts by Snell's law (n = 1.333) and reaches the floor; the pixel must show that
// floor point's colour absorbed over the refracted path (Beer-Lambert), weighed by (1 - F),
// plus the sky mirrored by Fresnel's share F (Schlick). Straight rays would land across the
// colours' border for a band of pixels, so the picture tells refraction from none. Then the
// composite: the layers read back, folded part by part (keep_nearer) and resolved, give the
// GPU's own picture bit for bit.
#include "render/DepthComposite.hpp"
#include "render/EglContext.hpp"
#include "render/EnvironmentMap.hpp"
#include "render/MeshRenderer.hpp"
#include "render/OffscreenTarget.hpp"
#include "render/WaterLayers.hpp"

#include <epoxy/gl.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>

using namespace kf;

namespace {

constexpr int kSize = 160;
constexpr double kDepth = 0.2, kBorder = 0.15; // the slab's depth; the colours' border, y
const glm::vec3 kNear{0.9f, 0.2f, 0.1f}, kFar{0.1f, 0.8f, 0.3f}; // floor at y < / > border
const glm::vec3 kTint{0.3f, 0.6f, 0.9f};                         // through 0.2 m of water
const glm::vec3 kCeiling{0.95f, 0.9f, 0.2f}; // high above: what the water mirrors, or the sky

/// An axis-aligned box, flat faces wound counter-clockwise seen from outside.
render::SurfaceMesh box(const glm::vec3& lo, const glm::vec3& hi) {
  render::SurfaceMesh m;
  for (int axis = 0; axis < 3; ++axis)
    for (int side = 0; side < 2; ++side) {
      glm::vec3 n(0.0f);
      n[axis] = side ? 1.0f : -1.0f;
      const int u = (axis + 1) % 3, v = (axis + 2) % 3;
      const auto first = std::uint32_t(m.position.size());
      for (int k = 0; k < 4; ++k) {
        glm::vec3 p;
        p[axis] = side ? hi[axis] : lo[axis];
        p[u] = (k == 1 || k == 2) ? hi[u] : lo[u];
        p[v] = (k >= 2) ? hi[v] : lo[v];
        m.position.push_back(p);
        m.normal.push_back(n);
      }
      // (u, v) counter-clockwise about +axis; reversed on the low side.
      if (side)
        m.index.insert(m.index.end(), {first, first + 1, first + 2, first, first + 2, first + 3});
      else
        m.index.insert(m.index.end(), {first, first + 2, first + 1, first, first + 3, first + 2});
    }
  return m;
}

render::SurfaceMesh quad(double y0, double y1, double z) {
  render::SurfaceMesh m;
  for (int k = 0; k < 4; ++k) {
    m.position.emplace_back(k & 1 ? 3.0f : -3.0f, k & 2 ? float(y1) : float(y0), float(z));
    m.normal.emplace_back(0.0f, 0.0f, 1.0f);
  }
  m.index = {0, 1, 3, 0, 3, 2};
  return m;
}

render::Camera camera() {
  render::Camera c;
  c.eye = {0, -1.2, 0.8};
  c.target = {0, 0, -0.2};
  c.fov_deg = 40;
  c.near = 0.1;
  c.far = 10;
  return c;
}

glm::dvec3 sky(const glm::dvec3& d) { // shaders/environment.glsl
  if (d.z < 0)
    return {0.55, 0.55, 0.53};
  const double t = std::clamp(d.z / 0.6, 0.0, 1.0), s = t * t * (3 - 2 * t);
  return glm::mix(glm::dvec3(0.86, 0.89, 0.93), glm::dvec3(0.42, 0.58, 0.85), s);
}

struct RefractionScene {
  render::EglContext context{-1};
  render::OffscreenTarget opaque{kSize, kSize}, picture{kSize, kSize};
  render::WaterLayers water{kSize, kSize};
  render::MeshRenderer floor_near, floor_far, slab, ceiling;
  render::EnvironmentMap environment{128};
  bool mirror_ceiling = false; // the water mirrors the ceiling (its cube map) or the sky
  render::Lighting unlit{{0, 0, 1}, 1.0f, 0.0f}; // ambient 1, no highlight: colour = albedo
  render::ViewMatrices view = render::ViewMatrices::of(camera(), 1.0);
  render::WaterOptics optics{1.333f, render::absorption_for(kTint, kDepth)};

  RefractionScene() {
    floor_near.upload(quad(-3, kBorder, -kDepth));
    floor_far.upload(quad(kBorder, 3, -kDepth));
    slab.upload(box({-1, -1, -kDepth}, {1, 1, 0}));
    render::SurfaceMesh c = quad(-100, 100, 3.0);
    for (auto& p : c.position)
      p.x *= 100.0f / 3.0f;
    ceiling.upload(c);
  }
  /// The opaque scene (either floor or both) and the water (or none) into the layers.
  void draw(bool near, bool far, bool with_water) {
    opaque.bind();
    glClearColor(1, 1, 1, 1);
    glClearDepth(1.0);
    glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
    if (near)
      floor_near.draw(glm::vec4(kNear, 1), view, unlit);
    if (far)
      floor_far.draw(glm::vec4(kFar, 1), view, unlit);
    unsigned mirrored = 0;
    if (mirror_ceiling) {
      environment.render({0, 0, -0.1}, 0.01, 500, [&](const render::ViewMatrices& v) {
        ceiling.draw(glm::vec4(kCeiling, 1), v, unlit);
        floor_near.draw(glm::vec4(kNear, 1), v, unlit);
        floor_far.draw(glm::vec4(kFar, 1), v, unlit);
      });
      mirrored = environment.texture();
    }
    water.begin_front();
    if (with_water)
      slab.draw(
          {}, view, unlit,
          {.reflective = true, .environment = mirrored, .water = render::MeshLook::Water::Front});
    water.begin_back();
    if (with_water)
      slab.draw({}, view, unlit, {.water = render::MeshLook::Water::Back});
  }
  std::vector<std::uint8_t> resolved() {
    water.resolve(opaque, view, optics, picture);
    return picture.read_rgba();
  }
  std::vector<render::LayeredPixel> layers() { return water.read(opaque); }
};

} // namespace

class RenderRefraction : public ::testing::TestWithParam<bool> {};

// Mirroring the sky (environment.glsl), or a yellow ceiling far above through the scene's cube
// map: every reflected ray from the slab's top meets it.
TEST_P(RenderRefraction, ASlabShowsTheFloorWhereSnellsLawSendsTheRayAbsorbedOnItsWay) {
  RefractionScene s;
  s.mirror_ceiling = GetParam();
  s.draw(true, true, true);
  const auto px = s.resolved();
  const render::Camera cam = camera();
  const glm::dmat4 to_world = glm::inverse(glm::dmat4(s.view.projection) * glm::dmat4(s.view.view));
  const glm::dvec3 sigma(s.optics.absorption);
  int checked = 0, bent = 0;
  double worst = 0;
  for (int j = 0; j < kSize; ++j)
    for (int i = 0; i < kSize; ++i) {
      // The ray through the pixel's centre (row j from the top).
      const glm::dvec2 ndc(2 * (i + 0.5) / kSize - 1, 1 - 2 * (j + 0.5) / kSize);
      const glm::dvec4 far = to_world * glm::dvec4(ndc, 1, 1);
      const glm::dvec3 d = glm::normalize(glm::dvec3(far) / far.w - cam.eye);
      if (d.z >= 0)
        continue;
      const glm::dvec3 top = cam.eye + d * (-cam.eye.z / d.z); // the slab's top, z = 0
      if (std::abs(top.x) > 0.8 || std::abs(top.y) > 0.8)
        continue; // its sides' pixels
      const glm::dvec3 t = glm::refract(d, glm::dvec3(0, 0, 1), 1 / 1.333);
      const double path = kDepth / -t.z;
      const glm::dvec3 floor = top + t * path;
      const glm::dvec3 straight = top + d * (kDepth / -d.z);
      if (std::abs(floor.y - kBorder) < 0.02 || std::abs(floor.x) > 0.95 ||
          std::abs(floor.y) > 0.95)
        continue; // the border's pixels (its footprint, ~5 mm), or under the slab's sides
      const glm::dvec4 seen =
          glm::dmat4(s.view.projection) * glm::dmat4(s.view.view) * glm::dvec4(floor, 1);
      if (std::abs(seen.x / seen.w) > 1 - 2.0 / kSize ||
          std::abs(seen.y / seen.w) > 1 - 2.0 / kSize)
        continue; // the refracted ray meets the floor off the picture: the resolve sees only it
      bent += (floor.y < kBorder) != (straight.y < kBorder);
      const double cos_i = -d.z;
      const double f = 0.02 + 0.98 * std::pow(1 - cos_i, 5);
      const glm::dvec3 base(floor.y < kBorder ? kNear : kFar);
      const glm::dvec3 mirrored =
          s.mirror_ceiling ? glm::dvec3(kCeiling) : sky(glm::reflect(d, glm::dvec3(0, 0, 1)));
      const glm::dvec3 want = f * mirrored + (1 - f) * base * glm::exp(-sigma * path);
      for (int c = 0; c < 3; ++c) {
        const double got = px[4 * (std::size_t(j) * kSize + i) + c];
        worst = std::max(worst, std::abs(got - 255 * want[c]));
        // 1.7 levels at most from four roundings to 8 bits: the surface's mirrored light (0.5),
        // F (0.5 / 255 of what comes through, up to 0.2), the floor's colour (0.5, absorbed)
        // and the picture's (0.5); measured 1.37 mirroring the sky, 1.57 the ceiling.
        EXPECT_NEAR(got, 255 * want[c], 1.8) << "pixel " << i << ", " << j << " channel " << c;
      }
      ++checked;
    }
  std::printf("%d pixels checked, %d of them bent across the border; worst %.2f levels\n", checked,
              bent, worst);
  EXPECT_GT(checked, kSize * kSize / 4) << "too few pixels see the slab's top";
  EXPECT_GT(bent, 200) << "too few pixels where refraction changes the colour seen";
}

INSTANTIATE_TEST_SUITE_P(MirroringTheSkyOrTheScene, RenderRefraction, ::testing::Bool());

// A drop before the background (nothing behind it but the far plane): the ray through its centre
// meets it head on, passes 2 r of water unbent and brings the background's white, absorbed.
TEST(RenderWater, ADropBeforeTheBackgroundAbsorbsOverItsDiameter) {
  RefractionScene s;
  render::SurfaceMesh drop;
  const double r = 0.05;
  const int rings = 48, sides = 96;
  for (int a = 0; a <= rings; ++a)
    for (int b = 0; b < sides; ++b) {
      const double th = M_PI * a / rings, ph = 2 * M_PI * b / sides;
      const glm::vec3 n(std::sin(th) * std::cos(ph), std::sin(th) * std::sin(ph), std::cos(th));
      drop.position.push_back(glm::vec3(0, 0, 0.3f) + float(r) * n);
      drop.normal.push_back(n);
    }
  for (int a = 0; a < rings; ++a)
    for (int b = 0; b < sides; ++b) {
      const auto at = [&](int i, int j) { return std::uint32_t(i * sides + (j % sides)); };
      // Counter-clockwise seen from outside: (a, b), (a + 1, b), (a + 1, b + 1), (a, b + 1).
      drop.index.insert(drop.index.end(), {at(a, b), at(a + 1, b), at(a + 1, b + 1), at(a, b),
                                           at(a + 1, b + 1), at(a, b + 1)});
    }
  render::MeshRenderer mesh;
  mesh.upload(drop);
  render::Camera cam;
  cam.eye = {0, -1, 0.3};
  cam.target = {0, 0, 0.3};
  cam.fov_deg = 20;
  cam.near = 0.1;
  cam.far = 100; // the background far away: the march must not take its scale from it
  const render::ViewMatrices view = render::ViewMatrices::of(cam, 1.0);
  s.opaque.bind();
  glClearColor(1, 1, 1, 1);
  glClearDepth(1.0);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  s.water.begin_front();
  mesh.draw({}, view, s.unlit, {.reflective = true, .water = render::MeshLook::Water::Front});
  s.water.begin_back();
  mesh.draw({}, view, s.unlit, {.water = render::MeshLook::Water::Back});
  s.water.resolve(s.opaque, view, s.optics, s.picture);
  const auto px = s.picture.read_rgba();
  // The centre pixel's ray is a hair off the axis: F = 0.02 of the ground mirrored behind the
  // eye's ray (the horizon's sky: the ray is level), the rest the white through 2 r of water.
  const std::size_t centre = 4 * (std::size_t(kSize / 2) * kSize + kSize / 2);
  const glm::dvec3 sigma(s.optics.absorption);
  for (int c = 0; c < 3; ++c) {
    const double want = 0.02 * sky({0, -1, 0})[c] + 0.98 * std::exp(-sigma[c] * 2 * r);
    // 2 levels: the pixel's ray is half a pixel off the centre (the path 2 r within 1e-4 of
    // itself), F and the mirrored light in 8 bits.
    EXPECT_NEAR(px[centre + std::size_t(c)], 255 * want, 2.0) << "channel " << c;
  }
}

TEST(RenderWater, TheCompositeOfPartsLayersResolvesToTheWholePicture) {
  RefractionScene s;
  s.draw(true, true, true);
  const auto whole = s.resolved();
  // Three parts: the near floor with the water, the far floor, nothing.
  s.draw(true, false, true);
  auto composite = s.layers();
  s.draw(false, true, false);
  auto far = s.layers();
  s.draw(false, false, false);
  auto none = s.layers();
  render::keep_nearer(none.data(), far.data(), far.size());
  render::keep_nearer(composite.data(), none.data(), none.size());
  s.water.write(composite, s.opaque);
  const auto parts = s.resolved();
  ASSERT_EQ(parts.size(), whole.size());
  std::size_t differ = 0;
  for (std::size_t k = 0; k < whole.size(); ++k)
    differ += parts[k] != whole[k];
  EXPECT_EQ(differ, 0u);
}
