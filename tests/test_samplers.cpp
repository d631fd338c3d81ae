// The samplers decide far points by bounds on boxes (domain/LatticeSieve, domain/ShapeBounds)
// instead of a distance a point. They must give the samples a distance a point gives, bit for
// bit and in the same order (a sample's id is its place): checked against that brute force,
// kept here as the reference, on every shipped scene and on random ones (each kind of solid,
// open walls, stretched lattices, jittered blocks). The bounds are checked against the
// distances at random points of each ball, and the sieve's classes point by point.
#include "domain/LatticeSieve.hpp"
#include "domain/MeshObstacle.hpp"
#include "domain/RigidShapes.hpp"
#include "domain/Samplers.hpp"
#include "domain/Scene.hpp"
#include "domain/ShapeBounds.hpp"
#include "kernels/particles/FluidSet.hpp"
#include "support/MeshReference.hpp"
#include "support/SceneFactory.hpp"
#include "support/TestPaths.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>

using namespace kf;

namespace {

// ---- The reference: a distance for every lattice point (the samplers before the sieve). ----

FluidSamples reference_fluid(const Scene& scene) {
  const RigidShapes<double> solids(scene);
  const auto& shapes = solids.table();
  const bool carve = scene.has(Module::Boundary);
  const double keep = 0.25 * scene.fluid.spacing;
  FluidSamples out;
  for (const auto& b : scene.fluid.blocks)
    for (const Vec3d& p : sample_fluid_block(b, scene.fluid.spacing)) {
      bool free = true;
      Vec3d n;
      if (carve)
        for (const auto& s : shapes)
          free = free && s.distance(p, n) >= keep;
      if (free) {
        out.x.push_back(p);
        out.v.push_back(b.velocity);
      }
    }
  return out;
}

std::vector<double> axis_points(double lo, double hi, double dp, double depth,
                                std::vector<double>& spacing) {
  std::vector<double> x;
  const int layers = static_cast<int>(std::ceil(depth / dp - 1e-9));
  const int n = std::max(1, static_cast<int>(std::lround((hi - lo) / dp)));
  const double s = (hi - lo) / n;
  for (int k = layers - 1; k >= 0; --k)
    x.push_back(lo - (k + 0.5) * dp), spacing.push_back(dp);
  for (int i = 0; i < n; ++i)
    x.push_back(lo + (i + 0.5) * s), spacing.push_back(s);
  for (int k = 0; k < layers; ++k)
    x.push_back(hi + (k + 0.5) * dp), spacing.push_back(dp);
  return x;
}

BoundarySamples reference_boundary(const Scene& scene, double dp, double depth) {
  const RigidShapes<double> solids(scene);
  const auto& shapes = solids.table();
  const std::size_t container = scene.obstacles.size();
  std::vector<double> sx, sy, sz;
  const auto ax = axis_points(scene.domain.min.x, scene.domain.max.x, dp, depth, sx);
  const auto ay = axis_points(scene.domain.min.y, scene.domain.max.y, dp, depth, sy);
  const auto az = axis_points(scene.domain.min.z, scene.domain.max.z, dp, depth, sz);
  BoundarySamples out;
  for (std::size_t k = 0; k < az.size(); ++k)
    for (std::size_t j = 0; j < ay.size(); ++j)
      for (std::size_t i = 0; i < ax.size(); ++i) {
        const Vec3d p{ax[i], ay[j], az[k]};
        for (std::size_t s = 0; s < shapes.size(); ++s) {
          Vec3d n;
          const double d = shapes[s].distance(p, n);
          if (d < 0 && d >= -depth) {
            out.x.push_back(p);
            out.obstacle.push_back(s == container ? kWallObstacle : static_cast<std::uint32_t>(s));
            out.volume_scale.push_back(sx[i] * sy[j] * sz[k] / (dp * dp * dp));
            break;
          }
        }
      }
  return out;
}

bool same_bits(const Vec3d& a, const Vec3d& b) {
  return std::memcmp(&a, &b, sizeof(Vec3d)) == 0;
}

/// Both samplers against the reference, every sample bit for bit and in order.
void expect_reference_samples(const Scene& scene, const std::string& what) {
  SCOPED_TRACE(what);
  const double dp = scene.fluid.spacing, depth = scene.support_radius();
  if (scene.has(Module::Fluid)) {
    const FluidSamples want = reference_fluid(scene);
    FluidSamples got;
    SamplerWork work;
    for_each_fluid_sample(
        scene,
        [&](const Vec3d& x, const Vec3d& v) {
          got.x.push_back(x);
          got.v.push_back(v);
        },
        &work);
    ASSERT_EQ(got.size(), want.size());
    for (std::size_t i = 0; i < want.size(); ++i) {
      ASSERT_TRUE(same_bits(got.x[i], want.x[i])) << "fluid sample " << i;
      ASSERT_TRUE(same_bits(got.v[i], want.v[i])) << "fluid sample " << i;
    }
  }
  if (scene.has(Module::Boundary)) {
    const BoundarySamples want = reference_boundary(scene, dp, depth);
    const BoundarySamples got = sample_boundaries(scene, dp, depth);
    ASSERT_EQ(got.x.size(), want.x.size());
    for (std::size_t i = 0; i < want.x.size(); ++i) {
      ASSERT_TRUE(same_bits(got.x[i], want.x[i])) << "boundary sample " << i;
      ASSERT_EQ(got.obstacle[i], want.obstacle[i]) << "boundary sample " << i;
      ASSERT_EQ(got.volume_scale[i], want.volume_scale[i]) << "boundary sample " << i;
    }
  }
}

Vec3d random_unit(std::mt19937_64& rng) {
  std::normal_distribution<double> g;
  Vec3d n{g(rng), g(rng), g(rng)};
  return n * (1.0 / norm(n));
}

Obstacle icosphere(const std::string& name, const Vec3d& c, double r) {
  const auto path = test::scratch_dir(name) / "ball.obj";
  std::ofstream(path) << test::icosphere_obj(2, c, r);
  Obstacle o;
  o.shape = ObstacleShape::Mesh;
  o.file = path.string();
  o.mesh = load_mesh_obstacle(path.string(), 1.0, {0, 0, 0});
  return o;
}

} // namespace

TEST(Samplers, EveryShippedSceneSamplesAsADistanceAPointDoes) {
  int scenes = 0;
  for (const char* dir : {"scenes", "scenes/stress", "scenes/studies", "scenes/bench"})
    for (const auto& e : std::filesystem::directory_iterator(test::source_dir() / dir))
      if (e.path().extension() == ".toml") {
        const Scene s = load_scene(e.path().string());
        expect_reference_samples(s, e.path().string());
        ++scenes;
      }
  EXPECT_GE(scenes, 15);
}

TEST(Samplers, RandomScenesSampleAsADistanceAPointDoes) {
  std::mt19937_64 rng(20261203);
  std::uniform_real_distribution<double> u(0, 1);
  for (int trial = 0; trial < 24; ++trial) {
    const double dp = 0.01;
    // Sides that are not multiples of dp stretch the boundary's lattice (axis_lattice).
    const Vec3d size{0.1 + 0.17 * u(rng), 0.1 + 0.13 * u(rng), 0.1 + 0.15 * u(rng)};
    Scene s = test::tank_scene(size, size, dp);
    s.fluid.support = 1.2 + 1.3 * u(rng); // the shell's depth, in dp
    for (int w = 0; w < 6; ++w)
      s.domain.walls[w] = u(rng) < 0.8;
    // Blocks reaching past the domain, into and around the solids; some jittered, some moving.
    s.fluid.blocks.clear();
    for (int b = 0, nb = 1 + trial % 3; b < nb; ++b) {
      FluidBlock blk;
      blk.min = {-0.02 + 0.1 * u(rng) * size.x, -0.02 + 0.1 * u(rng) * size.y, -0.02};
      blk.max = {size.x * (0.5 + 0.6 * u(rng)), size.y * (0.5 + 0.6 * u(rng)),
                 size.z * (0.4 + 0.6 * u(rng))};
      blk.jitter = trial % 2 ? 0.4 * u(rng) : 0.0;
      blk.velocity = {u(rng), 0, -u(rng)};
      s.fluid.blocks.push_back(blk);
    }
    const auto somewhere = [&] { return Vec3d{size.x * u(rng), size.y * u(rng), size.z * u(rng)}; };
    for (int o = 0, no = trial % 5; o < no; ++o) {
      Obstacle ob;
      switch ((trial + o) % 4) {
      case 0:
        ob.shape = ObstacleShape::Sphere;
        ob.center = somewhere();
        ob.radius = 0.01 + 0.05 * u(rng);
        break;
      case 1:
        ob.shape = ObstacleShape::Box;
        ob.min = somewhere();
        ob.max = ob.min + Vec3d{0.01 + 0.08 * u(rng), 0.01 + 0.08 * u(rng), 0.005 + 0.05 * u(rng)};
        break;
      case 2:
        ob.shape = ObstacleShape::Plane;
        ob.point = somewhere();
        ob.normal = random_unit(rng);
        break;
      default:
        ob = icosphere("samplers_mesh_" + std::to_string(trial), somewhere(), 0.02 + 0.04 * u(rng));
        break;
      }
      s.obstacles.push_back(ob);
    }
    expect_reference_samples(s, "trial " + std::to_string(trial));
  }
}

TEST(Samplers, JitteredBlocksBesideDiagonalPlanes) {
  // A plane across a box's diagonal makes the bound exact at the box's corner: its distance
  // there is the centre's less the box's radius. A jittered point at that corner may then lie
  // up to the jitter nearer the plane than its lattice position; a sieve that forgot the
  // jitter's spread keeps a point the distance carves (or the reverse). Every diagonal, the
  // largest jitter a scene may ask (0.5), planes through the block at several offsets.
  const double dp = 0.01;
  int scenes = 0;
  for (int diagonal = 0; diagonal < 4; ++diagonal)
    for (const double offset : {-0.031, 0.0, 0.017, 0.044}) {
      Scene s = test::tank_scene({0.3, 0.3, 0.3}, {0.3, 0.3, 0.3}, dp);
      s.fluid.blocks = {{{0.02, 0.02, 0.02}, {0.28, 0.27, 0.26}, {0, 0, 0}, 0.5}};
      Obstacle plane;
      plane.shape = ObstacleShape::Plane;
      plane.normal =
          Vec3d{diagonal & 1 ? -1.0 : 1.0, diagonal & 2 ? -1.0 : 1.0, 1.0} * (1.0 / std::sqrt(3.0));
      plane.point = Vec3d{0.15, 0.15, 0.15} + plane.normal * offset;
      s.obstacles = {plane};
      expect_reference_samples(s, "diagonal " + std::to_string(diagonal) + " offset " +
                                      std::to_string(offset));
      ++scenes;
    }
  EXPECT_EQ(scenes, 16);
}

TEST(Samplers, TheBoundsDecideMostOfTheDamBreaksLattices) {
  // The dam break at dp 2.5 mm (1,024,000 fluid; its walls' lattice 6.64M points, 496,704 of
  // them samples): by distance a point, every point evaluated. With the sieve, boxes are bounded
  // where the shells are far, and only the points of the boxes of at most 64 points straddling
  // a shell's faces (or near the walls the fluid's block touches) are evaluated. Measured (the
  // counts are deterministic): walls 18.4% of the points evaluated alone and 0.88% bounded as
  // boxes; fluid 15.8% and 1.00%. Bounds 10% above: a sieve that halves too far or decides
  // less fails (by points: 100%).
  Scene s =
      load_scene((test::source_dir() / "scenes/dambreak.toml").string(), {"fluid.spacing=0.0025"});
  SamplerWork wall, fluid, reference;
  reference.by_points = true;
  std::size_t walls = 0, water = 0, water_by_points = 0;
  for_each_boundary_sample(
      s, s.fluid.spacing, s.support_radius(), [&](const Vec3d&, std::uint32_t, double) { ++walls; },
      &wall);
  for_each_fluid_sample(
      s, [&](const Vec3d&, const Vec3d&) { ++water; }, &fluid);
  for_each_fluid_sample(
      s, [&](const Vec3d&, const Vec3d&) { ++water_by_points; }, &reference);
  EXPECT_EQ(walls, 496704u);
  EXPECT_EQ(water, water_by_points);
  EXPECT_EQ(reference.tested, reference.points); // by points: each point evaluated
  EXPECT_EQ(reference.boxes, 0u);
  const double pts = double(wall.points), fpts = double(fluid.points);
  std::printf("walls: %llu points, %.4f tested, %.4f boxes; fluid: %llu points, %.4f tested, "
              "%.4f boxes\n",
              (unsigned long long)wall.points, wall.tested / pts, wall.boxes / pts,
              (unsigned long long)fluid.points, fluid.tested / fpts, fluid.boxes / fpts);
  EXPECT_LT(wall.tested / pts, 0.202);
  EXPECT_LT(wall.boxes / pts, 0.0097);
  EXPECT_LT(fluid.tested / fpts, 0.174);
  EXPECT_LT(fluid.boxes / fpts, 0.011);
}

TEST(ShapeBounds, HoldAtEveryPointOfTheBall) {
  // Each kind of solid, balls of every size around and across its surface; the distance at
  // random points of each ball (and on its sphere, where a bound is nearest) must lie within.
  Scene s = test::tank_scene({0.3, 0.2, 0.25}, {0.1, 0.1, 0.1}, 0.01);
  s.domain.walls = {true, true, false, true, true, true};
  Obstacle sphere, box, plane;
  sphere.shape = ObstacleShape::Sphere;
  sphere.center = {0.1, 0.1, 0.1};
  sphere.radius = 0.04;
  box.shape = ObstacleShape::Box;
  box.min = {0.15, 0.05, 0.02};
  box.max = {0.22, 0.12, 0.07};
  plane.shape = ObstacleShape::Plane;
  plane.point = {0.2, 0.1, 0.1};
  plane.normal = Vec3d{1, 2, 2} * (1.0 / 3.0);
  s.obstacles = {sphere, box, plane, icosphere("shape_bounds_mesh", {0.2, 0.1, 0.15}, 0.03)};
  const RigidShapes<double> solids(s);
  const ShapeBounds bounds(solids.table());
  ASSERT_EQ(bounds.size(), 5u);
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-0.1, 0.4);
  std::size_t bounded_mesh = 0;
  for (std::size_t k = 0; k < bounds.size(); ++k)
    for (int ball = 0; ball < 400; ++ball) {
      const Vec3d c{u(rng), u(rng), u(rng)};
      const double r = 0.002 + 0.1 * std::abs(u(rng));
      const DistanceBounds b = bounds.over(k, c, r);
      ASSERT_LE(b.lower, b.upper);
      if (solids.table()[k].kind == ShapeKind::Mesh && std::isfinite(b.lower))
        ++bounded_mesh;
      for (int p = 0; p < 50; ++p) {
        const Vec3d dir = random_unit(rng);
        const double t = p < 10 ? r : r * std::cbrt(std::abs(u(rng)) / 0.4);
        Vec3d n;
        const double d = solids.table()[k].distance(c + dir * t, n);
        ASSERT_GE(d, b.lower) << "shape " << k << " ball " << ball;
        ASSERT_LE(d, b.upper) << "shape " << k << " ball " << ball;
      }
    }
  EXPECT_GT(bounded_mesh, 100u); // the mesh is bounded outside its grid, not only unbounded
}

TEST(LatticeSieve, AUniformBoxsClassHoldsAtEachOfItsPoints) {
  // A lattice with uneven steps and a jitter; classes from two spheres' exact distances (0:
  // outside both by 0.01, 1: inside the first, kSieveMaybe otherwise). Every point given 0 or 1
  // must have it at its own (jittered) position, and most of the points must be decided.
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(0, 1);
  std::array<std::vector<double>, 3> axes;
  for (int a = 0; a < 3; ++a) {
    double x = -0.1 * u(rng);
    for (int i = 0; i < 41 + 7 * a; ++i)
      axes[a].push_back(x += 0.002 + 0.01 * u(rng));
  }
  const double spread = 0.003;
  const Vec3d c1{0.2, 0.2, 0.25}, c2{0.05, 0.3, 0.1};
  const double r1 = 0.12, r2 = 0.06;
  const BallClassifier classify = [&](const Vec3d& c, double r) -> std::uint8_t {
    const double d1 = norm(c - c1) - r1, d2 = norm(c - c2) - r2;
    if (d1 + r < 0)
      return 1;
    if (d1 - r >= 0.01 && d2 - r >= 0.01)
      return 0;
    return kSieveMaybe;
  };
  const LatticeSieve sieve(axes, spread, classify);
  std::size_t points = 0, decided = 0;
  int last[3] = {-1, 0, 0};
  sieve.for_each([&](int i, int j, int k, std::uint8_t c) {
    // In order: x fastest, then y, then z.
    const bool next = (i == last[0] + 1 && j == last[1] && k == last[2]) ||
                      (i == 0 && j == last[1] + 1 && k == last[2]) ||
                      (i == 0 && j == 0 && k == last[2] + 1);
    ASSERT_TRUE(next) << i << " " << j << " " << k;
    last[0] = i, last[1] = j, last[2] = k;
    ++points;
    if (c == kSieveMaybe)
      return;
    ++decided;
    // A point anywhere within the spread of its lattice position.
    const Vec3d p =
        Vec3d{axes[0][i], axes[1][j], axes[2][k]} + random_unit(rng) * (spread * u(rng));
    const double d1 = norm(p - c1) - r1, d2 = norm(p - c2) - r2;
    if (c == 1)
      ASSERT_LT(d1, 0.0);
    else
      ASSERT_TRUE(d1 >= 0.01 && d2 >= 0.01);
  });
  EXPECT_EQ(points, axes[0].size() * axes[1].size() * axes[2].size());
  EXPECT_GT(decided, points / 2);
}
