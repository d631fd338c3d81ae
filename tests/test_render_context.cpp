// The render stage's base (P6 stage 1): a headless OpenGL 4.5 core context through EGL (Mesa's
// llvmpipe on the CI machine, NVIDIA's EGL device on a GPU machine), an offscreen target read
// back, and PNG files. Checked against independent references: which pixels a triangle covers
// follows from GL's rule (a pixel is drawn when its centre lies inside), computed here with edge
// functions; the depth test keeps the nearer of two triangles; a PNG reads back byte for byte.
#include "core/Error.hpp"
#include "io/PngImage.hpp"
#include "render/EglContext.hpp"
#include "render/OffscreenTarget.hpp"
#include "render/ShaderProgram.hpp"
#include "support/TestPaths.hpp"

#include <epoxy/gl.h>
#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>

using namespace kf;

namespace {

// A triangle a draw, its corners (x, y, z in clip space, w = 1) and colour from uniforms: no
// vertex buffers needed (gl_VertexID picks the corner).
constexpr const char* kVertex = R"(#version 450 core
uniform vec3 corner[3];
void main() { gl_Position = vec4(corner[gl_VertexID], 1.0); }
)";
constexpr const char* kFragment = R"(#version 450 core
uniform vec4 colour;
out vec4 frag;
void main() { frag = colour; }
)";

struct Tri {
  std::array<std::array<float, 3>, 3> c;
  std::array<float, 4> colour;
};

void draw(const render::ShaderProgram& prog, unsigned vao, const Tri& t) {
  prog.use();
  glUniform3fv(glGetUniformLocation(prog.id(), "corner"), 3, &t.c[0][0]);
  glUniform4fv(glGetUniformLocation(prog.id(), "colour"), 1, t.colour.data());
  glBindVertexArray(vao);
  glDrawArrays(GL_TRIANGLES, 0, 3);
}

/// Whether the centre of pixel (i, j) (j counted from the top) of a w x h image lies inside the
/// triangle's projection (either winding), and how far from its nearest edge in pixels.
bool covers(const Tri& t, int i, int j, int w, int h, double* margin) {
  const double px = -1 + (i + 0.5) * 2.0 / w, py = 1 - (j + 0.5) * 2.0 / h;
  double e[3];
  double least = 1e30;
  for (int k = 0; k < 3; ++k) {
    const auto& a = t.c[std::size_t(k)];
    const auto& b = t.c[std::size_t((k + 1) % 3)];
    const double ex = b[0] - a[0], ey = b[1] - a[1];
    e[k] = ex * (py - a[1]) - ey * (px - a[0]);
    // The distance to the edge's line, in pixels (x and y scaled to pixels).
    const double len = std::hypot(ex * w / 2, ey * h / 2);
    least = std::min(least, std::abs(e[k]) * (w / 2.0) * (h / 2.0) / len);
  }
  *margin = least;
  return (e[0] > 0 && e[1] > 0 && e[2] > 0) || (e[0] < 0 && e[1] < 0 && e[2] < 0);
}

} // namespace

TEST(RenderContext, HeadlessCoreContextIs45) {
  render::EglContext ctx;
  const auto& info = ctx.info();
  EXPECT_GE(info.major * 10 + info.minor, 45) << info.version;
  EXPECT_FALSE(info.renderer.empty());
  std::printf("EGL %s platform: %s | %s | %s%s\n", info.platform.c_str(), info.vendor.c_str(),
              info.renderer.c_str(), info.version.c_str(), info.software ? " (software)" : "");
}

// Random triangles in a 97 x 61 image: the pixels drawn are exactly those whose centres lie
// inside (pixels whose centre lies within 1e-3 pixel of an edge are left out of the count:
// there the rule's tie-break and the rasterizer's fixed point decide).
TEST(RenderContext, TrianglesCoverExactlyThePixelsWhoseCentresLieInside) {
  render::EglContext ctx;
  const int w = 97, h = 61;
  render::OffscreenTarget target(w, h);
  render::ShaderProgram prog("test triangle", kVertex, kFragment);
  unsigned vao = 0;
  glCreateVertexArrays(1, &vao);
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(-1.2f, 1.2f);
  std::size_t checked = 0, inside = 0;
  for (int n = 0; n < 20; ++n) {
    Tri t{{{{u(rng), u(rng), 0}, {u(rng), u(rng), 0}, {u(rng), u(rng), 0}}}, {1, 0, 0, 1}};
    target.bind();
    glClearColor(0, 0, 1, 1);
    glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
    glDisable(GL_DEPTH_TEST);
    draw(prog, vao, t);
    ASSERT_EQ(glGetError(), GLenum(GL_NO_ERROR));
    const auto px = target.read_rgba();
    for (int j = 0; j < h; ++j)
      for (int i = 0; i < w; ++i) {
        double margin = 0;
        const bool in = covers(t, i, j, w, h, &margin);
        if (margin < 1e-3)
          continue;
        const std::uint8_t* p = &px[(std::size_t(j) * w + i) * 4];
        const bool red = p[0] == 255 && p[1] == 0 && p[2] == 0 && p[3] == 255;
        const bool blue = p[0] == 0 && p[1] == 0 && p[2] == 255 && p[3] == 255;
        ASSERT_TRUE(in ? red : blue) << "triangle " << n << ", pixel (" << i << ", " << j
                                     << ") should be " << (in ? "drawn" : "clear");
        ++checked;
        inside += in;
      }
  }
  glDeleteVertexArrays(1, &vao);
  // 7,059 of 118,330 pixels inside (6%) for these triangles.
  EXPECT_GT(inside, checked / 25) << "the triangles cover too little to test";
}

// Two overlapping triangles, the far one drawn last: with the depth test the near one shows
// where they overlap, and the depth read back is (z + 1) / 2 there (within 24-bit depth).
TEST(RenderContext, DepthTestKeepsTheNearerSurface) {
  render::EglContext ctx;
  const int w = 64, h = 64;
  render::OffscreenTarget target(w, h);
  render::ShaderProgram prog("test depth", kVertex, kFragment);
  unsigned vao = 0;
  glCreateVertexArrays(1, &vao);
  target.bind();
  glClearColor(0, 0, 0, 1);
  glClearDepth(1.0);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LESS);
  const Tri near{{{{-0.9f, -0.9f, -0.5f}, {0.9f, -0.9f, -0.5f}, {0.0f, 0.9f, -0.5f}}},
                 {0, 1, 0, 1}};
  const Tri far{{{{-0.9f, 0.9f, 0.25f}, {0.9f, 0.9f, 0.25f}, {0.0f, -0.9f, 0.25f}}}, {1, 0, 0, 1}};
  draw(prog, vao, near);
  draw(prog, vao, far);
  const auto px = target.read_rgba();
  const auto depth = target.read_depth();
  glDeleteVertexArrays(1, &vao);
  std::size_t both = 0, far_only = 0;
  for (int j = 0; j < h; ++j)
    for (int i = 0; i < w; ++i) {
      double m1 = 0, m2 = 0;
      const bool in_near = covers(near, i, j, w, h, &m1), in_far = covers(far, i, j, w, h, &m2);
      if (m1 < 1e-3 || m2 < 1e-3)
        continue;
      const std::size_t k = std::size_t(j) * w + i;
      const std::uint8_t* p = &px[k * 4];
      if (in_near) {
        ASSERT_TRUE(p[0] == 0 && p[1] == 255) << "pixel (" << i << ", " << j << ")";
        EXPECT_NEAR(depth[k], 0.25, 1.0 / (1 << 23)) << "pixel (" << i << ", " << j << ")";
        both += in_far;
      } else if (in_far) {
        ASSERT_TRUE(p[0] == 255 && p[1] == 0) << "pixel (" << i << ", " << j << ")";
        EXPECT_NEAR(depth[k], 0.625, 1.0 / (1 << 23)) << "pixel (" << i << ", " << j << ")";
        ++far_only;
      } else {
        EXPECT_EQ(depth[k], 1.0f) << "pixel (" << i << ", " << j << ")";
      }
    }
  EXPECT_GT(both, 200u);
  EXPECT_GT(far_only, 200u);
}

TEST(RenderContext, RenderedImageRoundTripsThroughPng) {
  render::EglContext ctx;
  render::OffscreenTarget target(33, 20);
  target.bind();
  glClearColor(0.25f, 0.5f, 0.75f, 1.0f);
  glClear(GL_COLOR_BUFFER_BIT);
  io::RgbaImage img{33, 20, target.read_rgba()};
  // A gradient on top of the clear, so rows and columns are told apart.
  for (int j = 0; j < img.height; ++j)
    for (int i = 0; i < img.width; ++i)
      img.pixels[(std::size_t(j) * img.width + i) * 4] = std::uint8_t(7 * i + 3 * j);
  const auto dir = std::filesystem::temp_directory_path() / "kf_test_render_png";
  std::filesystem::create_directories(dir);
  const std::string path = (dir / "frame.png").string();
  io::write_png(path, img);
  const io::RgbaImage back = io::read_png(path);
  EXPECT_EQ(back.width, img.width);
  EXPECT_EQ(back.height, img.height);
  EXPECT_EQ(back.pixels, img.pixels);
  // 0.5 of 255 is 127.5: GL's conversion rounds to the nearest, the tie either way (llvmpipe
  // gives 128, NVIDIA 127).
  EXPECT_TRUE(back.pixels[1] == 127 || back.pixels[1] == 128) << int(back.pixels[1]);
  EXPECT_FALSE(std::filesystem::exists(path + ".tmp"));
  // Bad input names the file.
  { std::ofstream(dir / "not.png") << "not a png"; }
  try {
    io::read_png((dir / "not.png").string());
    FAIL() << "a text file read as a PNG";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("not.png: not a PNG file"), std::string::npos) << e.what();
  }
  std::filesystem::remove_all(dir);
}
