// The knit's yarns as tubes (render/YarnTubes, P6): the mesh against its geometry (a straight
// yarn is a prism of the ring's polygon: every vertex at the radius from the axis, the area
// L 2 n r sin(pi / n)); rotation-minimising rings (on a helix the rings do not turn about the
// yarn: no twist); yarns kept apart at their ends; a wet yarn thicker and darker by
// 1 - alpha sqrt(s); a k-d split's boxes share the segments out exactly; and the picture: the
// tube's width on the image is its projected diameter.
#include "core/Error.hpp"
#include "render/MeshRenderer.hpp"
#include "render/OffscreenTarget.hpp"
#include "render/SnapshotRender.hpp"
#include "render/TubeRenderer.hpp"
#include "render/YarnTubes.hpp"

#include <epoxy/gl.h>
#include <gtest/gtest.h>

#include <glm/gtc/matrix_transform.hpp>

#include <algorithm>
#include <cmath>
#include <set>

using namespace kf;
using render::YarnPolylines;
using render::YarnStyle;

namespace {

/// One yarn through the points, joined in order, the last its end.
YarnPolylines chain(const std::vector<glm::dvec3>& x, double s = 0) {
  YarnPolylines y;
  y.x = x;
  for (std::uint32_t i = 0; i < x.size(); ++i)
    y.segment.push_back({i, i + 1 < x.size() ? i + 1 : i});
  y.s.assign(x.size(), s);
  return y;
}

} // namespace

TEST(YarnTubes, AStraightYarnIsAPrismOfItsRing) {
  std::vector<glm::dvec3> x;
  for (int i = 0; i <= 10; ++i)
    x.push_back({0.1 * i, 0.2, -0.3});
  YarnStyle st;
  st.radius = 0.01;
  st.sides = 8;
  const auto m = render::yarn_tubes(chain(x), st);
  ASSERT_EQ(m.position.size(), 11u * 8);
  EXPECT_EQ(m.triangles(), 10u * 8 * 2);
  for (std::size_t v = 0; v < m.position.size(); ++v) {
    const glm::dvec3 p(m.position[v]), n(m.normal[v]);
    const double d = std::hypot(p.y - 0.2, p.z + 0.3);
    // Float positions near 0.3 lie 3e-8 apart, and the ring is built in float (as on the GPU):
    // an ulp and a little (measured 2.1e-8).
    EXPECT_NEAR(d, 0.01, 4e-8) << "vertex " << v;
    EXPECT_NEAR(glm::length(n), 1.0, 1e-6);
    EXPECT_NEAR(n.x, 0.0, 1e-6) << "a normal along the axis";
    // Outward: the normal is the vertex's offset from the axis over the radius.
    EXPECT_NEAR(glm::length(glm::dvec3(0, p.y - 0.2, p.z + 0.3) / 0.01 - n), 0.0, 1e-5);
    EXPECT_FLOAT_EQ(m.shade[v], 1.0f); // dry
  }
  // Triangles wound counter-clockwise seen from outside: their normals point away from the axis.
  for (std::size_t t = 0; t < m.index.size(); t += 3) {
    const glm::dvec3 p0(m.position[m.index[t]]), p1(m.position[m.index[t + 1]]),
        p2(m.position[m.index[t + 2]]);
    const glm::dvec3 c = (p0 + p1 + p2) / 3.0, out(0, c.y - 0.2, c.z + 0.3);
    EXPECT_GT(glm::dot(glm::cross(p1 - p0, p2 - p0), out), 0) << "triangle " << t / 3;
  }
  const double want = 1.0 * 2 * 8 * 0.01 * std::sin(M_PI / 8);
  EXPECT_NEAR(m.area(), want, 1e-6 * want);
}

TEST(YarnTubes, TheRingsDoNotTurnAboutTheYarn) {
  // A helix (radius R, pitch 2 pi c): its Frenet frame turns about the tangent by the torsion
  // c / (R^2 + c^2) = 6.9 rad/m, 0.0117 rad a step of h = 1.7 mm. A rotation-minimising frame
  // does not: the change of a ring's first direction r has no part along b = t x r. Measured
  // 2.5e-6 a step (the finite difference's h^3 and float normals); the bound, 1e-5, is 1/1000 of
  // the Frenet frame's twist. Every vertex lies at r from its point.
  const double R = 0.05, c = 0.02, r = 0.002;
  std::vector<glm::dvec3> x;
  for (int i = 0; i <= 400; ++i) {
    const double t = 2 * M_PI * i / 200;
    x.push_back({R * std::cos(t), R * std::sin(t), c * t});
  }
  YarnStyle st;
  st.radius = r;
  st.sides = 4; // vertex 0 along r, vertex 1 along b
  const auto m = render::yarn_tubes(chain(x), st);
  double worst = 0;
  for (std::size_t i = 0; i + 1 < x.size(); ++i) {
    const glm::dvec3 ri(m.normal[i * 4]), rn(m.normal[(i + 1) * 4]);
    const glm::dvec3 b_mid =
        glm::dvec3(m.normal[i * 4 + 1]) + glm::dvec3(m.normal[(i + 1) * 4 + 1]);
    // Against b half-way between the rings: the difference's part along b is then of h^3.
    worst = std::max(worst, std::abs(glm::dot(rn - ri, 0.5 * b_mid)));
    for (int k = 0; k < 4; ++k)
      EXPECT_NEAR(glm::length(glm::dvec3(m.position[i * 4 + k]) - x[i]), r, 1e-7);
  }
  EXPECT_LT(worst, 1e-5) << "the rings turn about the yarn";
  std::printf("largest turn of a ring about the yarn: %.3g rad a step (Frenet: 0.0117)\n", worst);
}

TEST(YarnTubes, YarnsStayApartAndBadSegmentsAreErrors) {
  YarnPolylines y;
  y.x = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {0, 1, 0}, {1, 1, 0}, {2, 1, 0}};
  y.segment = {{0, 1}, {1, 2}, {2, 2}, {3, 4}, {4, 5}, {5, 5}};
  YarnStyle st;
  st.radius = 0.1;
  st.sides = 4;
  const auto m = render::yarn_tubes(y, st);
  EXPECT_EQ(m.triangles(), 4u * 4 * 2);
  for (std::size_t t = 0; t < m.index.size(); t += 3) {
    const std::uint32_t lo = std::min({m.index[t], m.index[t + 1], m.index[t + 2]}) / 4,
                        hi = std::max({m.index[t], m.index[t + 1], m.index[t + 2]}) / 4;
    EXPECT_EQ(hi - lo, 1u) << "a triangle spans points " << lo << ".." << hi;
    EXPECT_NE(lo, 2u) << "yarn 0's end joined to yarn 1";
  }
  y.segment[1] = {1, 3};
  try {
    render::yarn_tubes(y, st);
    FAIL() << "a segment skipping a point was taken";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("yarn point 1's segment (1, 3)"), std::string::npos)
        << e.what();
  }
  y.segment[1] = {1, 2};
  y.s = {0, 0};
  EXPECT_THROW(render::yarn_tubes(y, st), Error); // 2 saturations for 6 points
}

TEST(YarnTubes, AWetYarnIsThickerAndDarker) {
  YarnStyle st;
  st.radius = 0.01;
  st.sides = 5;
  for (double s : {0.0, 0.25, 1.0}) {
    const auto m = render::yarn_tubes(chain({{0, 0, 0}, {1, 0, 0}}, s), st);
    for (std::size_t v = 0; v < m.position.size(); ++v) {
      EXPECT_NEAR(std::hypot(m.position[v].y, m.position[v].z), 0.01 * (1 + 0.1 * s), 1e-9);
      EXPECT_NEAR(m.shade[v], 1 - 0.15 * std::sqrt(s), 1e-7) << "s = " << s;
    }
  }
}

TEST(YarnTubes, ASplitsBoxesShareTheSegmentsOut) {
  std::vector<glm::dvec3> x;
  for (int i = 0; i < 50; ++i)
    x.push_back({0.02 * i, 0.01 * std::sin(0.3 * i), 0});
  YarnStyle st;
  st.radius = 0.003;
  const auto whole = render::yarn_tubes(chain(x), st);
  const auto boxes = render::kd_split(x, 3);
  std::multiset<std::vector<std::uint32_t>> parts;
  for (const auto& b : boxes) {
    const auto m = render::yarn_tubes(chain(x), st, &b);
    for (std::size_t t = 0; t < m.index.size(); t += 3)
      parts.insert({m.index[t], m.index[t + 1], m.index[t + 2]});
  }
  std::multiset<std::vector<std::uint32_t>> all;
  for (std::size_t t = 0; t < whole.index.size(); t += 3)
    all.insert({whole.index[t], whole.index[t + 1], whole.index[t + 2]});
  EXPECT_EQ(parts, all) << "every triangle drawn by exactly one box";
}

TEST(RenderYarn, ATubesWidthOnThePictureIsItsProjectedDiameter) {
  // A straight yarn across the view, seen square on: the tube covers a band as wide as the
  // projection of its diameter at its distance (within a pixel a side: the band's edges are
  // rasterised polygon silhouettes).
  io::Frame f;
  std::vector<float> x, seg_s;
  std::vector<std::uint32_t> seg;
  const int n = 41;
  for (int i = 0; i < n; ++i) {
    x.insert(x.end(), {-0.2f + 0.01f * float(i), 0.0f, 0.0f});
    seg.insert(seg.end(), {std::uint32_t(i), std::uint32_t(i + 1 < n ? i + 1 : i)});
    seg_s.push_back(0);
  }
  f.phases.push_back({"yarn",
                      {io::Field::from("position", x, 3), io::Field::from("segment", seg, 2),
                       io::Field::from("saturation", seg_s, 1)}});
  render::SnapshotStyle style;
  style.width = 320;
  style.height = 240;
  style.yarn_radius = 0.03;
  render::SnapshotRenderer r(style);
  render::Camera cam;
  cam.eye = {0, -1, 0};
  cam.target = {0, 0, 0};
  cam.up = {0, 0, 1};
  const io::RgbaImage img = r.draw(f, cam);
  const auto depth = r.depth();
  // The band's height in the middle column.
  int covered = 0;
  for (int row = 0; row < style.height; ++row)
    covered += depth[std::size_t(row) * style.width + style.width / 2] < 1.0f;
  // The silhouette of an 8-sided tube seen across: between the ring's flat-to-flat and
  // corner-to-corner extents (r cos(pi/8) and r); perspective from 1 m: rays graze the tube a
  // little behind its axis (a 3% effect at r / d = 0.03).
  const glm::mat4 pv = cam.projection(double(style.width) / style.height) * cam.view();
  auto rows = [&](double half) {
    const glm::vec4 top = pv * glm::vec4(0, 0, float(half), 1),
                    bot = pv * glm::vec4(0, 0, float(-half), 1);
    return (top.y / top.w - bot.y / bot.w) / 2 * style.height;
  };
  const double lo = rows(0.03 * std::cos(M_PI / 8)), hi = rows(0.03);
  EXPECT_GE(covered, int(std::floor(lo)) - 1);
  EXPECT_LE(covered, int(std::ceil(hi)) + 1);
  std::printf("tube band %d pixels, projected diameter %.2f-%.2f\n", covered, lo, hi);
  EXPECT_GT(r.last_triangles(), 0u);
  EXPECT_EQ(r.last_spheres(), 0u); // no knit points drawn as spheres
}

TEST(RenderYarn, TheGpusTubesAreTheHostMeshsTubes) {
  // A wet helix drawn as the host's mesh (yarn_tubes through MeshRenderer, the reference) and
  // by TubeRenderer: rings built in tube.vert from the host's frames, and from frames computed
  // on the GPU (what SnapshotRenderer draws). The same arithmetic in another order and
  // precision: the same picture but for pixels on a silhouette.
  render::EglContext context;
  std::vector<glm::dvec3> x;
  for (int i = 0; i < 400; ++i) {
    const double a = 0.05 * i;
    x.push_back({0.1 * std::cos(a), 0.1 * std::sin(a), 0.004 * a});
  }
  auto y = chain(x, 0);
  for (std::size_t i = 0; i < y.s.size(); ++i)
    y.s[i] = double(i) / double(y.s.size()); // drier to wetter along it
  YarnStyle st;
  st.radius = 0.01;
  render::Camera cam;
  cam.eye = {0.35, -0.35, 0.3};
  cam.target = {0, 0, 0.04};
  cam.up = {0, 0, 1};
  const int w = 320, h = 240;
  const auto view = render::ViewMatrices::of(cam, double(w) / h);
  const glm::vec4 colour(0.85f, 0.55f, 0.25f, 1.0f);
  render::OffscreenTarget target(w, h);
  auto picture = [&](auto&& draw) {
    target.bind();
    glClearColor(1, 1, 1, 1);
    glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
    draw();
    return target.read_rgba();
  };
  render::MeshRenderer mesh;
  mesh.upload(render::yarn_tubes(y, st));
  const auto host = picture([&] { mesh.draw(colour, view); });
  render::TubeRenderer tubes;
  auto compare = [&](const std::vector<std::uint8_t>& gpu, const char* what) {
    std::size_t covered = 0, differ = 0;
    int worst = 0;
    for (std::size_t i = 0; i < host.size(); i += 4) {
      int d = 0;
      for (std::size_t c = 0; c < 3; ++c)
        d = std::max(d, std::abs(int(gpu[i + c]) - int(host[i + c])));
      worst = std::max(worst, d);
      differ += d > 2;
      covered += host[i + 2] != 255;
    }
    std::printf("tubes (%s): %zu pixels covered, %zu differ by more than 2 levels (largest %d)\n",
                what, covered, differ, worst);
    EXPECT_GT(covered, 5000u);
    EXPECT_LE(differ, covered / 200) << what; // silhouette pixels only: 0.5% allowed
  };
  tubes.upload(render::yarn_frames(y, st), st.sides);
  EXPECT_EQ(tubes.triangles(), 399u * 2 * 8);
  compare(picture([&] { tubes.draw(colour, view); }), "host frames, rings in tube.vert");
  // The frames in float on the GPU (yarn_frames.comp): the same rings to rounding.
  tubes.build(render::yarn_points(y), st);
  EXPECT_EQ(tubes.triangles(), 399u * 2 * 8);
  compare(picture([&] { tubes.draw(colour, view); }), "frames on the GPU");
}
