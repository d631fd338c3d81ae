// Ray-cast sphere impostors (render/SphereRenderer, P6 stage 2) against a ray caster written
// here from the camera's definition (eye, target, up, vertical field of view), without GLM: each
// pixel shows the sphere its ray meets first, or the background; and the depth written is the
// hit point's. On llvmpipe in CI.
#include "render/Camera.hpp"
#include "render/EglContext.hpp"
#include "render/OffscreenTarget.hpp"
#include "render/SphereRenderer.hpp"

#include <epoxy/gl.h>
#include <gtest/gtest.h>

#include <cmath>

using namespace kf;

namespace {

struct V {
  double x, y, z;
};
V operator-(V a, V b) {
  return {a.x - b.x, a.y - b.y, a.z - b.z};
}
V operator+(V a, V b) {
  return {a.x + b.x, a.y + b.y, a.z + b.z};
}
V operator*(V a, double s) {
  return {a.x * s, a.y * s, a.z * s};
}
double dot(V a, V b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}
V cross(V a, V b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
V unit(V a) {
  return a * (1 / std::sqrt(dot(a, a)));
}

struct Ball {
  V c;
  double r;
};

/// The index of the first sphere the ray from the eye through image point (u, v) (pixels, v
/// from the top) meets, or -1; t: its distance along the unit ray.
int first_hit(const render::Camera& cam, int w, int h, double u, double v,
              const std::vector<Ball>& balls, double* t_hit) {
  const V eye{cam.eye.x, cam.eye.y, cam.eye.z}, target{cam.target.x, cam.target.y, cam.target.z};
  const V fwd = unit(target - eye);
  const V right = unit(cross(fwd, V{cam.up.x, cam.up.y, cam.up.z}));
  const V up = cross(right, fwd);
  const double half = std::tan(cam.fov_deg * M_PI / 360), aspect = double(w) / h;
  const double sx = (2 * u / w - 1) * half * aspect, sy = (1 - 2 * v / h) * half;
  const V dir = unit(fwd + right * sx + up * sy);
  int best = -1;
  double best_t = 1e30;
  for (std::size_t k = 0; k < balls.size(); ++k) {
    const V oc = balls[k].c - eye;
    const double b = dot(dir, oc), disc = b * b - (dot(oc, oc) - balls[k].r * balls[k].r);
    if (disc < 0)
      continue;
    const double t = b - std::sqrt(disc);
    if (t > 0 && t < best_t) {
      best_t = t;
      best = int(k);
    }
  }
  *t_hit = best_t;
  return best;
}

} // namespace

TEST(RenderSpheres, EachPixelShowsTheSphereItsRayMeetsFirst) {
  render::EglContext ctx;
  const int w = 160, h = 120;
  render::OffscreenTarget target(w, h);
  render::SphereRenderer spheres;
  // Three spheres: two that intersect, one partly behind them, one off to the side.
  const std::vector<Ball> balls{{{0.0, 0.0, 0.0}, 0.30},
                                {{0.25, 0.1, 0.05}, 0.22},
                                {{-0.2, 0.5, 0.1}, 0.35},
                                {{-0.55, -0.3, -0.1}, 0.12}};
  const glm::vec4 colours[] = {{1, 0, 0, 1}, {0, 1, 0, 1}, {0, 0, 1, 1}, {1, 1, 0, 1}};
  std::vector<render::Sphere> list;
  for (std::size_t k = 0; k < balls.size(); ++k)
    list.push_back({glm::vec4(balls[k].c.x, balls[k].c.y, balls[k].c.z, balls[k].r), colours[k]});
  render::Camera cam;
  cam.eye = {1.2, -1.9, 0.9};
  cam.target = {0, 0.05, 0};
  cam.up = {0, 0, 1};
  cam.fov_deg = 40;
  cam.near = 0.5;
  cam.far = 5;
  target.bind();
  glClearColor(0, 0, 0, 0); // alpha 0 marks the background: every sphere writes alpha 1
  glClearDepth(1.0);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  spheres.draw(list, cam, double(w) / h);
  const auto px = target.read_rgba();
  const auto depth = target.read_depth();
  const glm::mat4 proj = cam.projection(double(w) / h);
  std::size_t checked = 0, hits[4] = {0, 0, 0, 0};
  for (int j = 0; j < h; ++j)
    for (int i = 0; i < w; ++i) {
      // Certain pixels only: the centre and four points half a pixel out agree (edges and the
      // curve where two spheres meet are left to the rasterizer's sampling).
      double t = 0, t2 = 0;
      const int k = first_hit(cam, w, h, i + 0.5, j + 0.5, balls, &t);
      bool certain = true;
      for (const auto& d : {std::pair{0.0, 0.5}, {0.0, -0.5}, {0.5, 0.0}, {-0.5, 0.0}})
        certain =
            certain && first_hit(cam, w, h, i + 0.5 + d.first, j + 0.5 + d.second, balls, &t2) == k;
      if (!certain)
        continue;
      ++checked;
      const std::uint8_t* p = &px[(std::size_t(j) * w + i) * 4];
      if (k < 0) {
        ASSERT_EQ(p[3], 0) << "pixel (" << i << ", " << j << ") should show no sphere";
        ASSERT_EQ(depth[std::size_t(j) * w + i], 1.0f);
        continue;
      }
      ++hits[k];
      ASSERT_EQ(p[3], 255) << "pixel (" << i << ", " << j << ") should show sphere " << k;
      // The base colour's channels dominate (lighting scales them; the highlight adds grey).
      const glm::vec4 c = colours[k];
      for (int ch = 0; ch < 3; ++ch)
        for (int o = 0; o < 3; ++o) {
          if (c[ch] > 0 && c[o] == 0) {
            ASSERT_GT(p[ch], p[o]) << "pixel (" << i << ", " << j << ") should show sphere " << k;
          }
        }
      // Depth: the hit point's, through the camera's projection (view-space z = -t cos of the
      // ray's angle to the axis; here from the hit point itself).
      const V eye{cam.eye.x, cam.eye.y, cam.eye.z}, tgt{cam.target.x, cam.target.y, cam.target.z};
      const V fwd = unit(tgt - eye);
      const V right = unit(cross(fwd, V{0, 0, 1}));
      const V up = cross(right, fwd);
      const double half = std::tan(cam.fov_deg * M_PI / 360), aspect = double(w) / h;
      const V dir = unit(fwd + right * ((2 * (i + 0.5) / w - 1) * half * aspect) +
                         up * ((1 - 2 * (j + 0.5) / h) * half));
      const double z_view = -t * dot(dir, fwd);
      const double ndc = (proj[2][2] * z_view + proj[3][2]) / (-z_view);
      EXPECT_NEAR(depth[std::size_t(j) * w + i], 0.5 * ndc + 0.5, 2e-5)
          << "pixel (" << i << ", " << j << ")";
    }
  EXPECT_GT(checked, std::size_t(w * h * 9 / 10));
  for (int k = 0; k < 4; ++k)
    EXPECT_GT(hits[k], 30u) << "sphere " << k << " is hardly seen: the test sees too little";
}

// framing() keeps the whole box in view: the box's 8 corners project inside the image.
TEST(RenderSpheres, FramingKeepsTheBoxInView) {
  const glm::dvec3 lo{-0.1, 0.2, 0.0}, hi{0.9, 0.6, 0.4};
  for (double aspect : {0.5, 1.0, 16.0 / 9}) {
    const render::Camera cam = render::Camera::framing(lo, hi, aspect);
    const glm::mat4 m = cam.projection(aspect) * cam.view();
    for (int c = 0; c < 8; ++c) {
      const glm::vec4 p =
          m * glm::vec4(c & 1 ? hi.x : lo.x, c & 2 ? hi.y : lo.y, c & 4 ? hi.z : lo.z, 1.0);
      EXPECT_LT(std::abs(p.x / p.w), 1.0) << "aspect " << aspect << ", corner " << c;
      EXPECT_LT(std::abs(p.y / p.w), 1.0) << "aspect " << aspect << ", corner " << c;
      EXPECT_LT(std::abs(p.z / p.w), 1.0) << "aspect " << aspect << ", corner " << c;
    }
  }
}
