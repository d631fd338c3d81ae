// The environment map the water mirrors (P6, render/EnvironmentMap): six coloured balls around
// its centre, one on each axis and one off them. Every texel of every face, read back, must
// show the ball that a ray from the centre in the texel's direction meets first (or nothing:
// alpha 0), the direction taken from GL's cube map table (OpenGL 4.5, table 8.19), not from the
// code's own face views: a face turned or mirrored shows the wrong ball.
#include "render/EglContext.hpp"
#include "render/EnvironmentMap.hpp"
#include "render/SphereRenderer.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

using namespace kf;

namespace {

/// The direction of texel (i, j) of face k (row j at t = (j + 1/2) / n), by the table.
glm::dvec3 texel_direction(int k, int i, int j, int n) {
  const double sc = 2 * (i + 0.5) / n - 1, tc = 2 * (j + 0.5) / n - 1;
  switch (k) {
  case 0:
    return {1, -tc, -sc};
  case 1:
    return {-1, -tc, sc};
  case 2:
    return {sc, 1, tc};
  case 3:
    return {sc, -1, -tc};
  case 4:
    return {sc, -tc, 1};
  default:
    return {-sc, -tc, -1};
  }
}

} // namespace

TEST(RenderEnvironment, EveryTexelShowsTheBallItsDirectionMeetsFirst) {
  render::EglContext context(-1);
  const glm::dvec3 centre(0.3, -0.2, 0.5);
  // A ball on each side of the centre, each its own colour, and one between +x and +z in front
  // of two others' edges; unlit (ambient 1, no highlight): a texel is its ball's colour.
  struct Ball {
    glm::dvec3 c;
    double r;
    glm::vec3 colour;
  };
  const std::vector<Ball> balls = {
      {{1.0, 0.1, 0.0}, 0.4, {1.0f, 0.0f, 0.0f}},  {{-1.2, 0.0, 0.2}, 0.5, {0.0f, 1.0f, 0.0f}},
      {{0.1, 0.9, -0.1}, 0.3, {0.0f, 0.0f, 1.0f}}, {{0.0, -1.1, 0.3}, 0.6, {1.0f, 1.0f, 0.0f}},
      {{-0.2, 0.2, 1.3}, 0.5, {0.0f, 1.0f, 1.0f}}, {{0.2, -0.1, -0.9}, 0.4, {1.0f, 0.0f, 1.0f}},
      {{0.6, 0.0, 0.6}, 0.25, {0.5f, 0.25f, 1.0f}}};
  std::vector<render::Sphere> spheres;
  for (const Ball& b : balls)
    spheres.push_back({glm::vec4(glm::vec3(centre + b.c), float(b.r)), glm::vec4(b.colour, 1)});
  render::SphereRenderer renderer;
  renderer.upload(spheres);
  const render::Lighting unlit{{0, 0, 1}, 1.0f, 0.0f};
  const int n = 64;
  render::EnvironmentMap map(n);
  map.render(centre, 0.01, 10, [&](const render::ViewMatrices& v) { renderer.draw(v, unlit); });
  int checked = 0, on_balls = 0;
  for (int k = 0; k < 6; ++k) {
    const auto px = map.read_face(k);
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        const glm::dvec3 d = glm::normalize(texel_direction(k, i, j, n));
        // The nearest ball along d, and how far the ray passes from any silhouette (a texel
        // spans ~2/n rad: one within 2 texels of an edge is left out).
        int hit = -1;
        double nearest = 1e30, edge = 1e30;
        for (std::size_t b = 0; b < balls.size(); ++b) {
          const double along = glm::dot(balls[b].c, d);
          const double miss = glm::length(balls[b].c - along * d);
          if (along > 0)
            edge = std::min(edge, std::abs(miss - balls[b].r) / along);
          if (along > 0 && miss < balls[b].r) {
            const double t = along - std::sqrt(balls[b].r * balls[b].r - miss * miss);
            if (t < nearest) {
              nearest = t;
              hit = int(b);
            }
          }
        }
        if (edge < 4.0 / n)
          continue;
        const std::uint8_t* p = &px[4 * (std::size_t(j) * n + i)];
        ++checked;
        if (hit < 0) {
          EXPECT_EQ(p[3], 0) << "face " << k << " texel " << i << ", " << j << ": drawn";
          continue;
        }
        ++on_balls;
        EXPECT_EQ(p[3], 255) << "face " << k << " texel " << i << ", " << j;
        for (int c = 0; c < 3; ++c)
          ASSERT_NEAR(p[c], 255 * balls[std::size_t(hit)].colour[c], 1.0)
              << "face " << k << " texel " << i << ", " << j << ": not ball " << hit;
      }
  }
  std::printf("%d texels checked, %d of them on a ball\n", checked, on_balls);
  EXPECT_GT(on_balls, 6 * n * n / 10);
  EXPECT_GT(checked - on_balls, 6 * n * n / 10);
}
