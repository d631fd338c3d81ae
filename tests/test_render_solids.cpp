// The scene's solids drawn (render/SolidMeshes, P6): a box's mesh is its six faces (area
// 2 (ab + bc + ca), every face wound counter-clockwise seen from outside, normals out); a plane's
// square faces its fluid side; on the picture a box's top face takes the light a face up takes,
// C (ambient + (1 - ambient) l_z), and a plane is seen from its front and not from behind (a
// tank's wall does not hide what is in it).
#include "core/Error.hpp"
#include "render/SnapshotRender.hpp"
#include "render/SolidMeshes.hpp"

#include <gtest/gtest.h>

#include <cmath>

using namespace kf;

namespace {

/// Every triangle's winding normal points away from `inside` and agrees with its vertices'.
void expect_outward(const render::SurfaceMesh& m, const glm::dvec3& inside) {
  for (std::size_t t = 0; t < m.index.size(); t += 3) {
    const glm::dvec3 a(m.position[m.index[t]]), b(m.position[m.index[t + 1]]),
        c(m.position[m.index[t + 2]]);
    const glm::dvec3 w = glm::cross(b - a, c - a);
    EXPECT_GT(glm::dot(w, (a + b + c) / 3.0 - inside), 0) << "triangle " << t / 3;
    EXPECT_GT(glm::dot(w, glm::dvec3(m.normal[m.index[t]])), 0) << "triangle " << t / 3;
  }
}

/// A camera at eye looking at target, depth from 0.1 to 10.
render::Camera camera_at(const glm::dvec3& eye, const glm::dvec3& target, const glm::dvec3& up) {
  render::Camera c;
  c.eye = eye;
  c.target = target;
  c.up = up;
  c.near = 0.1;
  c.far = 10;
  return c;
}

} // namespace

TEST(SolidMeshes, ABoxIsItsSixFacesWoundOutward) {
  const auto m = render::box_mesh({-1, 0, 2}, {2, 0.5, 4});
  EXPECT_EQ(m.triangles(), 12u);
  EXPECT_NEAR(m.area(), 2 * (3 * 0.5 + 0.5 * 2 + 2 * 3), 1e-6);
  expect_outward(m, {0.5, 0.25, 3});
}

TEST(SolidMeshes, APlaneFacesItsFluidAndTrianglesKeepTheirWinding) {
  const glm::dvec3 n = glm::normalize(glm::dvec3(1, -2, 0.5));
  const auto m = render::plane_mesh({0.3, 0.1, 0}, n, {5, 5, 5}, 2.0);
  EXPECT_NEAR(m.area(), 16.0, 1e-5);
  for (std::size_t v = 0; v < m.position.size(); ++v) {
    EXPECT_NEAR(glm::dot(glm::dvec3(m.position[v]) - glm::dvec3(0.3, 0.1, 0), n), 0, 1e-5);
    EXPECT_NEAR(glm::length(glm::dvec3(m.normal[v]) - n), 0, 1e-6);
  }
  expect_outward(m, glm::dvec3(0.3, 0.1, 0) - n);
  // A tetrahedron as an OBJ mesh's triangles (counter-clockwise outside), one of them bad.
  const std::vector<glm::dvec3> v = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  const auto t = render::triangle_mesh(v, {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}});
  EXPECT_EQ(t.triangles(), 4u);
  expect_outward(t, {0.2, 0.2, 0.2});
  EXPECT_THROW(render::triangle_mesh(v, {{0, 1, 4}}), Error);
}

TEST(SolidMeshes, ATanksWallsAreTheBoxsFacesAskedForWoundInward) {
  // x-, y+ and z- of the box [0, 2] x [0, 1] x [0, 3]: areas 1 x 3, 2 x 3 and 2 x 1, each
  // wound counter-clockwise seen from inside (its normal toward the box's centre).
  const glm::dvec3 lo(0, 0, 0), hi(2, 1, 3), centre = 0.5 * (lo + hi);
  const auto m = render::box_inside(lo, hi, {true, false, false, true, true, false});
  EXPECT_EQ(m.triangles(), 6u);
  EXPECT_NEAR(m.area(), 3.0 + 6.0 + 2.0, 1e-6);
  for (std::size_t t = 0; t < m.index.size(); t += 3) {
    const glm::dvec3 a(m.position[m.index[t]]), b(m.position[m.index[t + 1]]),
        c(m.position[m.index[t + 2]]);
    const glm::dvec3 w = glm::cross(b - a, c - a);
    EXPECT_GT(glm::dot(w, centre - (a + b + c) / 3.0), 0) << "triangle " << t / 3;
    EXPECT_GT(glm::dot(w, glm::dvec3(m.normal[m.index[t]])), 0) << "triangle " << t / 3;
    // On the face it belongs to: x = 0, y = 1 or z = 0 throughout.
    const bool on_x = a.x == 0 && b.x == 0 && c.x == 0, on_y = a.y == 1 && b.y == 1 && c.y == 1,
               on_z = a.z == 0 && b.z == 0 && c.z == 0;
    EXPECT_TRUE(on_x || on_y || on_z) << "triangle " << t / 3;
  }
  // All six inside are the box's own faces turned round: the same area.
  EXPECT_NEAR(render::box_inside(lo, hi, {true, true, true, true, true, true}).area(),
              render::box_mesh(lo, hi).area(), 1e-6);
}

TEST(SolidMeshes, APlaneIsDrawnWhereItCutsTheDomain) {
  // Level with the box's faces: the face's area; through a cube's centre across its diagonal:
  // the regular hexagon of side a / sqrt 2, area 3 sqrt(3) / 4 a^2; past the box: nothing.
  const glm::dvec3 lo(0, 0, 0), hi(2, 1, 3);
  const auto level = render::plane_in_box({5, 5, 0.3}, {0, 0, 1}, lo, hi);
  EXPECT_NEAR(level.area(), 2.0, 1e-6);
  expect_outward(level, {1, 0.5, 0});
  const glm::dvec3 n = glm::normalize(glm::dvec3(1, 1, 1));
  const auto hexagon = render::plane_in_box({0.5, 0.5, 0.5}, n, {0, 0, 0}, {1, 1, 1});
  EXPECT_EQ(hexagon.triangles(), 4u);
  EXPECT_NEAR(hexagon.area(), 3 * std::sqrt(3.0) / 4, 1e-6);
  expect_outward(hexagon, glm::dvec3(0.5) - n);
  EXPECT_EQ(render::plane_in_box({0, 0, 5}, {0, 0, 1}, lo, hi).triangles(), 0u);
  // obstacles.toml's sloping floor: every corner on the plane and in the box.
  const glm::dvec3 p(0, 0, 0.05), slope = glm::normalize(glm::dvec3(0.1, 0, 1));
  const auto floor = render::plane_in_box(p, slope, {0, 0, 0}, {0.6, 0.4, 0.6});
  EXPECT_EQ(floor.triangles(), 2u);
  for (const glm::vec3& q : floor.position) {
    EXPECT_NEAR(glm::dot(glm::dvec3(q) - p, slope), 0, 1e-6);
    EXPECT_TRUE(q.x >= -1e-6f && q.x <= 0.6f + 1e-6f && q.y >= -1e-6f && q.y <= 0.4f + 1e-6f &&
                q.z >= -1e-6f && q.z <= 0.6f + 1e-6f);
  }
  expect_outward(floor, p - slope);
}

TEST(RenderSolids, ABoxsTopTakesTheLightAndAPlaneShowsOnlyItsFront) {
  render::SnapshotStyle s;
  s.width = 200;
  s.height = 200;
  s.lighting.toward_light = {0.3f, 0.2f, 1.0f};
  s.lighting.specular = 0;
  s.solids = render::box_mesh({-0.1, -0.1, 0}, {0.1, 0.1, 0.2});
  render::Camera cam;
  cam.eye = {0, 0, 1};
  cam.target = {0, 0, 0};
  cam.up = {0, 1, 0};
  cam.near = 0.1;
  cam.far = 3;
  const std::size_t centre = 4 * (100 * 200 + 100);
  {
    render::SnapshotRenderer r(s);
    const io::RgbaImage img = r.draw(io::Frame{}, cam);
    const double lz = 1.0 / std::sqrt(0.09 + 0.04 + 1.0);
    const double want = 0.55 * (0.25 + 0.75 * lz) * 255;
    EXPECT_NEAR(img.pixels[centre], want, 1.0) << "the box's top face";
  }
  // A horizontal plane below, facing up: seen from above; facing down: not seen (background).
  s.solids = {};
  for (double nz : {1.0, -1.0}) {
    s.planes = render::plane_mesh({0, 0, 0}, {0, 0, nz}, {0, 0, 0}, 1.0);
    s.obstacles = {{glm::vec4(0.5f, 0.5f, 0.1f, 0.05f), glm::vec4(1.0f)}}; // (something to frame)
    render::SnapshotRenderer r(s);
    const io::RgbaImage img = r.draw(io::Frame{}, cam);
    if (nz > 0) {
      EXPECT_LT(img.pixels[centre], 200) << "the plane's front is not drawn";
    } else {
      EXPECT_EQ(img.pixels[centre], 255) << "the plane's back is drawn";
    }
  }
}

TEST(RenderSolids, ATanksNearWallsHideNothingAndItsWallsCastNoShadow) {
  // A tank [-0.5, 0.5]^2 x [0, 1] on the floor, its four sides drawn from inside, a ball in it.
  render::SnapshotStyle s;
  s.width = 160;
  s.height = 160;
  s.shadows = true;
  s.floor = true;
  s.floor_z = 0;
  s.lighting.specular = 0;
  s.obstacles = {{glm::vec4(0.0f, 0.0f, 0.3f, 0.1f), glm::vec4(0.9f, 0.1f, 0.1f, 1.0f)}};
  const auto walls = render::box_inside({-0.5, -0.5, 0}, {0.5, 0.5, 1}, {1, 1, 1, 1, 0, 0});
  auto picture = [&s](const render::SurfaceMesh& tank, const render::SurfaceMesh& planes,
                      const render::Camera& cam) {
    s.tank = tank;
    s.planes = planes;
    render::SnapshotRenderer r(s);
    return r.draw(io::Frame{}, cam).pixels;
  };
  auto at = [&s](int x, int y) { return std::size_t(4) * (std::size_t(y) * s.width + x); };
  // From the front: the near wall (y-) turns its back and is not drawn, so the ball shows as it
  // does without the tank; above it the far wall (y+) stands where the sky was.
  const render::Camera front = camera_at({0, -3, 0.3}, {0, 0, 0.3}, {0, 0, 1});
  const auto open = picture({}, {}, front), tank = picture(walls, {}, front);
  for (int c = 0; c < 3; ++c)
    EXPECT_EQ(tank[at(80, 80) + c], open[at(80, 80) + c]) << "the ball, channel " << c;
  EXPECT_GT(open[at(80, 80)], 2 * open[at(80, 80) + 1]) << "the ball is red";
  EXPECT_EQ(open[at(80, 30)], 255) << "the sky above the ball";
  EXPECT_LT(tank[at(80, 30)], 240) << "the far wall above the ball";
  // From above, the light low over the near wall (y-): the walls cast no shadow, so the floor
  // inside is lit as without them; the same walls as planes (casters) would shade it.
  s.lighting.toward_light = {0.0f, -1.0f, 1.2f};
  // (Pebbles in opposite corners, one up at the walls' top: the floor and the shadow maps
  // cover the frame's box.)
  s.obstacles = {{glm::vec4(0.45f, 0.45f, 0.98f, 0.02f), glm::vec4(1.0f)},
                 {glm::vec4(-0.45f, -0.45f, 0.02f, 0.02f), glm::vec4(1.0f)}};
  const render::Camera top = camera_at({0, 0, 3}, {0, 0, 0}, {0, 1, 0});
  const auto open_top = picture({}, {}, top), tank_top = picture(walls, {}, top),
             cast_top = picture({}, walls, top);
  for (int c = 0; c < 3; ++c)
    EXPECT_EQ(tank_top[at(80, 80) + c], open_top[at(80, 80) + c]) << "the floor, channel " << c;
  EXPECT_LT(cast_top[at(80, 80)] + 20, open_top[at(80, 80)]) << "a caster's shadow (control)";
}

TEST(RenderSolids, AMovingObstacleStandsWhereItsVelocityTookItAtTheFramesTime) {
  // The scene's prescribed motion, x(t) = x(0) + v t: a box and a sphere moving, drawn at
  // t = 0.5 s, are the still ones placed at x(0.5) (the same picture: a vertex an ulp apart may
  // move a silhouette pixel; measured on llvmpipe: none), and not where they started.
  const glm::vec3 v_box(0.2f, 0.0f, 0.0f), v_ball(0.0f, -0.1f, 0.05f);
  const double t = 0.5;
  render::Camera cam;
  cam.eye = {0.1, -1.2, 0.8};
  cam.target = {0.1, 0, 0.1};
  cam.up = {0, 0, 1};
  auto picture = [&](bool moving, double time) {
    render::SnapshotStyle s;
    s.width = 160;
    s.height = 120;
    const glm::dvec3 shift = moving ? glm::dvec3(0) : glm::dvec3(v_box) * t;
    s.solids =
        render::box_mesh(glm::dvec3(-0.1, -0.1, 0) + shift, glm::dvec3(0.1, 0.1, 0.2) + shift);
    const glm::vec3 ball_shift = moving ? glm::vec3(0) : v_ball * float(t);
    s.obstacles = {{glm::vec4(glm::vec3(0.3f, 0.2f, 0.1f) + ball_shift, 0.08f), glm::vec4(1.0f)}};
    if (moving) {
      s.solid_velocity.assign(s.solids.position.size(), v_box);
      s.obstacle_velocity = {v_ball};
    }
    io::Frame f;
    f.time = time;
    render::SnapshotRenderer r(s);
    return r.draw(f, cam).pixels;
  };
  const auto moved = picture(true, t), still_there = picture(false, t),
             at_start = picture(true, 0.0);
  std::size_t off = 0, differ = 0;
  for (std::size_t i = 0; i < moved.size(); i += 4) {
    off += std::abs(int(moved[i]) - int(still_there[i])) > 2;
    differ += moved[i] != at_start[i];
  }
  EXPECT_LE(off, 5u);
  EXPECT_GT(differ, 1000u) << "the obstacles did not move";
  // Velocities that do not match the obstacles are an error, not a silent still picture.
  render::SnapshotStyle bad;
  bad.solids = render::box_mesh({0, 0, 0}, {1, 1, 1});
  bad.solid_velocity = {v_box};
  render::SnapshotRenderer r(bad);
  EXPECT_THROW(r.draw(io::Frame{}, cam), Error);
}
