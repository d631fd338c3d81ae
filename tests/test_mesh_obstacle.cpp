// Mesh obstacles in scenes: the fluid's boundary shell fills the inside of a mesh like that of
// the sphere it approximates, fluid blocks are carved around it, and a knit patch dropped on a
// mesh rests on it with no point inside (checked against a brute-force winding-number
// reference, not the sampled distance the contact uses). Fluid containment of the example scene
// is in test_containment (it runs every scene file).
#include "domain/MeshObstacle.hpp"
#include "domain/Samplers.hpp"
#include "domain/Simulation.hpp"
#include "support/MeshReference.hpp"
#include "support/SceneFactory.hpp"
#include "support/TestPaths.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <numbers>
#if defined(_OPENMP)
#include <omp.h>
#endif

using namespace kf;

namespace {

/// The icosphere (c, r) as a mesh obstacle, through an OBJ file; r_in: its faces' least
/// distance from c, so the mesh lies between the spheres of radius r_in and r.
struct Ball {
  Obstacle obstacle;
  double r_in = 0;
};

Ball icosphere_obstacle(const std::string& name, const Vec3d& c, double r) {
  const auto path = test::scratch_dir(name) / "ball.obj";
  std::ofstream(path) << test::icosphere_obj(3, c, r);
  Ball b;
  b.obstacle.shape = ObstacleShape::Mesh;
  b.obstacle.file = path.string();
  b.obstacle.mesh = load_mesh_obstacle(path.string(), 1.0, {0, 0, 0});
  b.r_in = r;
  const MeshSolid& m = b.obstacle.mesh->solid;
  for (const auto& t : m.triangles) {
    const Vec3d n = cross(m.vertices[t[1]] - m.vertices[t[0]], m.vertices[t[2]] - m.vertices[t[0]]);
    b.r_in = std::min(b.r_in, dot(m.vertices[t[0]] - c, n) / norm(n));
  }
  return b;
}

} // namespace

TEST(MeshObstacle, BoundaryShellFillsTheMeshLikeTheSphereItApproximates) {
  const double dp = 0.01, depth = 0.02;
  const Vec3d c{0.15, 0.15, 0.12};
  const double r = 0.08;
  Scene s = test::tank_scene({0.3, 0.3, 0.3}, {0.3, 0.3, 0.25}, dp);
  const Ball ball = icosphere_obstacle("mesh_shell", c, r);
  s.obstacles = {ball.obstacle};
  const BoundarySamples b = sample_boundaries(s, dp, depth);
  Obstacle sphere;
  sphere.shape = ObstacleShape::Sphere;
  sphere.center = c;
  sphere.radius = r;
  s.obstacles = {sphere};
  const BoundarySamples bs = sample_boundaries(s, dp, depth);

  // The sampled distance is at least the sphere's (the mesh is convex and inside the sphere) and
  // at most (r - r_in) + interpolation error above it (test_mesh_sdf), so every particle of the
  // mesh's shell lies in the sphere's shell widened inward by that much.
  const double cell = ball.obstacle.mesh->sdf.cell;
  const double tol = (r - ball.r_in) + 3 * cell * cell / (8 * (r - depth - 2 * cell));
  std::size_t mesh_shell = 0, sphere_shell = 0;
  for (std::size_t i = 0; i < b.x.size(); ++i) {
    if (b.obstacle[i] != 0)
      continue;
    ++mesh_shell;
    // The sampled distance is in [-depth, 0), never below the sphere's, at most tol above it.
    const double d = norm(b.x[i] - c) - r;
    ASSERT_LT(d, 0.0);
    ASSERT_GE(d, -depth - tol);
  }
  for (std::uint32_t o : bs.obstacle)
    sphere_shell += o == 0;
  const double volume = 4.0 / 3 * std::numbers::pi * (std::pow(r, 3) - std::pow(r - depth, 3));
  std::printf("shell inside the mesh: %zu particles; inside the sphere: %zu; shell volume / dp^3 "
              "= %.0f (chord error %.2e m, tolerance %.2e m)\n",
              mesh_shell, sphere_shell, volume / (dp * dp * dp), r - ball.r_in, tol);
  EXPECT_NEAR(double(mesh_shell), double(sphere_shell), 0.05 * sphere_shell);
  EXPECT_NEAR(double(mesh_shell), volume / (dp * dp * dp), 0.1 * volume / (dp * dp * dp));
}

TEST(MeshObstacle, FluidBlocksAreCarvedAroundTheMesh) {
  const double dp = 0.01;
  const Vec3d c{0.15, 0.15, 0.1};
  const double r = 0.06;
  Scene s = test::tank_scene({0.3, 0.3, 0.3}, {0.3, 0.3, 0.2}, dp); // the ball is submerged
  const Ball ball = icosphere_obstacle("mesh_carve", c, r);
  s.obstacles = {ball.obstacle};
  const FluidSamples f = sample_fluid(s);
  const double cell = ball.obstacle.mesh->sdf.cell;
  const double tol = (r - ball.r_in) + 3 * cell * cell / (8 * (r - 2 * cell));
  std::size_t near = 0;
  for (const Vec3d& x : f.x) {
    const double d = norm(x - c) - r;
    // Kept only where the sampled distance is >= dp / 4, and that exceeds d by at most tol.
    ASSERT_GE(d, 0.25 * dp - tol);
    near += d < dp;
  }
  Obstacle sphere;
  sphere.shape = ObstacleShape::Sphere;
  sphere.center = c;
  sphere.radius = r;
  s.obstacles = {sphere};
  const std::size_t all = 30 * 30 * 20, kept_by_sphere = sample_fluid(s).size();
  const double carved = 4.0 / 3 * std::numbers::pi * std::pow(r + 0.25 * dp, 3) / std::pow(dp, 3);
  std::printf("fluid: %zu of %zu lattice points kept (%zu around the sphere), %zu within dp of "
              "the ball; ball + dp/4 holds %.0f lattice volumes\n",
              f.size(), all, kept_by_sphere, near, carved);
  EXPECT_GT(near, 100u) << "the pool should reach the ball";
  EXPECT_NEAR(double(all - f.size()), double(all - kept_by_sphere), 0.02 * (all - kept_by_sphere));
  EXPECT_NEAR(double(all - f.size()), carved, 0.1 * carved);
}

TEST(MeshObstacle, KnitPatchDroppedOnAMeshRestsOnItWithNoPointInside) {
  const std::string blob = (test::source_dir() / "scenes" / "meshes" / "blob.obj").string();
  // The blob (unit size) scaled to 0.1 m and standing on the floor; its top is at
  // 0.905531 * 0.1 + 0.08 = 0.1706 m. The patch starts 3 cm above it.
  const std::string text = R"(
[simulation]
end_time = 0.5
modules = ["knit"]
precision = "double"
[domain]
min = [-0.3, -0.3, 0]
max = [0.3, 0.3, 0.5]
[output]
enabled = false
[knit]
damping_ratio = 0.3
[[knit.piece]]
shape = "patch"
center = [0, 0, 0.2]
width = 0.24
height = 0.24
wales = 16
courses = 16
[[obstacle]]
shape = "mesh"
file = ")" + blob + R"("
scale = 0.1
translate = [0, 0, 0.08]
)";
  const Scene s = parse_scene(text, "<string>");
#if defined(_OPENMP)
  // 867 points: one thread does it in ~2 s. With two, the thousands of substeps' barriers crawl
  // while another test holds the cores (measured 200 s under ctest -j2).
  const int threads = omp_get_max_threads();
  omp_set_num_threads(1);
#endif
  const MeshSolid& solid = s.obstacles.at(0).mesh->solid;
  const test::RefMesh ref{solid.vertices, solid.triangles};
  auto sim = Simulation::create(s, exec::Backend::Cpu);
  double min_ref = 1e30;
  for (int check = 1; check <= 5; ++check) { // every 0.1 s, so passing through would show
    const double t = 0.1 * check;
    while (sim->time() < t - 1e-12)
      sim->step(t);
    const auto x = sim->frame().find("knit")->find("position")->as<double>();
    for (std::size_t i = 0; i < x.size(); i += 3)
      min_ref = std::min(min_ref, test::ref_signed_distance(ref, {x[i], x[i + 1], x[i + 2]}));
  }
#if defined(_OPENMP)
  omp_set_num_threads(threads);
#endif
  const Diagnostics d = sim->diagnostics();
  const auto x = sim->frame().find("knit")->find("position")->as<double>();
  double z_centre = 0, z_min = 1e30;
  const std::size_t n = x.size() / 3;
  for (std::size_t i = 0; i < n; ++i) {
    z_min = std::min(z_min, x[3 * i + 2]);
    if (std::hypot(x[3 * i], x[3 * i + 1]) < 0.02)
      z_centre = std::max(z_centre, x[3 * i + 2]);
  }
  std::printf("knit on the blob: %zu points, %llu contacts, closest to the mesh %.2e m by the "
              "exact reference (%.2e m by the sampled distance; contact radius %.1e m), centre "
              "at z = %.4f m, lowest point z = %.4f m\n",
              n, static_cast<unsigned long long>(d.knit_contacts), min_ref,
              d.knit_min_rigid_distance, s.knit.radius(), z_centre, z_min);
  EXPECT_GE(min_ref, 0.0) << "a knit point is inside the mesh";
  EXPECT_GT(d.knit_contacts, 0u);
  // Held up by the blob: the centre stays on its top while the rim drapes below it.
  EXPECT_GT(z_centre, 0.1706);
  EXPECT_LT(z_centre, 0.1706 + 0.01);
  EXPECT_LT(z_min, 0.15);
}
