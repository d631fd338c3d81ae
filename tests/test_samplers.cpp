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
#include "domain/SceneSampler.hpp"
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
#include <limits>
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

namespace {

/// A random tank: sides that are not multiples of dp (the boundary's lattice stretched), open
/// walls, blocks reaching past the domain, into and around the solids (some jittered, some
/// moving), and 0-4 solids of every kind.
Scene random_scene(std::mt19937_64& rng, int trial) {
  std::uniform_real_distribution<double> u(0, 1);
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
  return s;
}

} // namespace

TEST(Samplers, RandomScenesSampleAsADistanceAPointDoes) {
  std::mt19937_64 rng(20261203);
  for (int trial = 0; trial < 24; ++trial)
    expect_reference_samples(random_scene(rng, trial), "trial " + std::to_string(trial));
}

TEST(SceneSampler, SharesAndRegionsGiveTheScenesSamplesWithTheirIds) {
  // A rank of a split job samples a share of the layers, then its region with every layer's
  // count: the share's samples, in turn, must be the whole scene's in its order, and a region's
  // every sample of the scene in the box (by position), each with the whole pass's id, bit for
  // bit, ascending, and nothing that is not a sample.
  std::mt19937_64 rng(31);
  std::uniform_real_distribution<double> u(0, 1);
  std::size_t regions = 0, found = 0;
  for (int trial = 0; trial < 24; ++trial) {
    const Scene scene = random_scene(rng, trial);
    for (const auto kind : {SceneSampler::Kind::Fluid, SceneSampler::Kind::Boundary}) {
      SCOPED_TRACE("trial " + std::to_string(trial) +
                   (kind == SceneSampler::Kind::Fluid ? " fluid" : " boundary"));
      const SceneSampler sampler(scene, kind, scene.fluid.spacing, scene.support_radius());
      std::vector<Sample> whole;
      const auto layers = sampler.layer_samples(0, sampler.layers(), 0,
                                                [&](const Sample& q) { whole.push_back(q); });
      ASSERT_EQ(layers.size(), std::size_t(sampler.layers()));
      for (std::size_t i = 0; i < whole.size(); ++i)
        ASSERT_EQ(whole[i].id, i);
      const auto same = [](const Sample& a, const Sample& b) {
        return a.id == b.id && same_bits(a.x, b.x) && same_bits(a.v, b.v) &&
               a.obstacle == b.obstacle && a.volume_scale == b.volume_scale;
      };
      for (const int shares : {2, 3, 7}) {
        std::uint64_t next = 0;
        for (int r = 0; r < shares; ++r) {
          const int first = sampler.layers() * r / shares,
                    last = sampler.layers() * (r + 1) / shares;
          const auto counts = sampler.layer_samples(first, last, next, [&](const Sample& q) {
            ASSERT_LT(q.id, whole.size());
            ASSERT_TRUE(same(q, whole[q.id]));
            ASSERT_EQ(q.id, next);
            ++next;
          });
          ASSERT_TRUE(std::equal(counts.begin(), counts.end(), layers.begin() + first));
        }
        ASSERT_EQ(next, whole.size());
      }
      const Vec3d size = scene.domain.max - scene.domain.min;
      for (int box = 0; box < 6; ++box) {
        Vec3d lo{u(rng) * size.x, u(rng) * size.y, u(rng) * size.z}, hi = lo;
        hi += Vec3d{0.6 * u(rng) * size.x, 0.6 * u(rng) * size.y, 0.6 * u(rng) * size.z};
        if (box % 3 == 1) // open sides, as a rank's blocks at the grid's edge give
          lo.x = lo.z = -std::numeric_limits<double>::infinity();
        if (box % 3 == 2)
          hi.y = std::numeric_limits<double>::infinity();
        std::vector<Sample> got;
        sampler.samples_in(lo, hi, 0.0, layers, [&](const Sample& q) { got.push_back(q); });
        for (std::size_t i = 0; i < got.size(); ++i) {
          ASSERT_LT(got[i].id, whole.size());
          ASSERT_TRUE(same(got[i], whole[got[i].id])) << "sample " << got[i].id;
          if (i > 0) {
            ASSERT_LT(got[i - 1].id, got[i].id);
          }
        }
        std::size_t inside = 0, g = 0;
        for (const Sample& q : whole)
          if (q.x.x >= lo.x && q.x.x <= hi.x && q.x.y >= lo.y && q.x.y <= hi.y && q.x.z >= lo.z &&
              q.x.z <= hi.z) {
            ++inside;
            while (g < got.size() && got[g].id < q.id)
              ++g;
            ASSERT_TRUE(g < got.size() && got[g].id == q.id) << "sample " << q.id << " missed";
          }
        ++regions;
        found += inside;
      }
    }
  }
  EXPECT_GT(found, 10000u); // the boxes held samples, not only empty space
  EXPECT_EQ(regions, 24u * 2 * 6);
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

TEST(Samplers, TheBoundsDecideTheDamBreaksLatticesByBoxes) {
  // The dam break at dp 2.5 mm (1,024,000 fluid; its walls' lattice 6.64M points, 496,704 of
  // them samples): by distance a point, every point evaluated. The container's bounds over a box
  // are exact and its boxes are cut at the domain's faces first, so every point, the walls'
  // shells' too, is decided by a box: none evaluated alone, 148 boxes bounded for the walls and
  // 10 for the fluid (counted; deterministic). Twice those bound it: a sieve that halves where
  // it need not, or bounds the container loosely (a ball's bound: 1.26M points evaluated and
  // 59k boxes), fails.
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
  std::printf("walls: %llu points, %llu tested, %llu boxes; fluid: %llu points, %llu tested, "
              "%llu boxes\n",
              (unsigned long long)wall.points, (unsigned long long)wall.tested,
              (unsigned long long)wall.boxes, (unsigned long long)fluid.points,
              (unsigned long long)fluid.tested, (unsigned long long)fluid.boxes);
  EXPECT_EQ(wall.points, 6640704u);
  EXPECT_EQ(wall.tested, 0u);
  EXPECT_LE(wall.boxes, 2u * 148);
  EXPECT_EQ(fluid.tested, 0u);
  EXPECT_LE(fluid.boxes, 2u * 10);
}

TEST(SceneSampler, ARegionReadsItsOwnPointsNotTheScenes) {
  // The dam break at dp 2.5 mm: a rank's region 0.05 m of the domain's 0.8 along x (open in y
  // and z, as a split along x gives) reads the lattice points of the box alone, 1/16 of the
  // walls' lattice and a quarter of the fluid's block, and counts the rest of its layers by
  // boxes. Measured: walls 409,920 of 6,640,704 points read, none evaluated alone, 316 boxes;
  // fluid 256,000 of 1,024,000, 30 boxes. A pass over the scene reads every point.
  const Scene s =
      load_scene((test::source_dir() / "scenes/dambreak.toml").string(), {"fluid.spacing=0.0025"});
  const double inf = std::numeric_limits<double>::infinity();
  for (const auto kind : {SceneSampler::Kind::Boundary, SceneSampler::Kind::Fluid}) {
    const bool fluid = kind == SceneSampler::Kind::Fluid;
    const SceneSampler whole(s, kind, s.fluid.spacing, s.support_radius());
    std::size_t all = 0;
    const auto layers = whole.layer_samples(0, whole.layers(), 0, [&](const Sample&) { ++all; });
    const SamplerWork w = whole.work();
    const SceneSampler part(s, kind, s.fluid.spacing, s.support_radius());
    std::size_t mine = 0;
    part.samples_in({0.05, -inf, -inf}, {0.1, inf, inf}, 0.0, layers,
                    [&](const Sample&) { ++mine; });
    const SamplerWork p = part.work();
    std::printf("%s: the region read %llu of %llu points, evaluated %llu, %llu boxes; %zu of %zu "
                "samples\n",
                fluid ? "fluid" : "walls", (unsigned long long)p.points,
                (unsigned long long)w.points, (unsigned long long)p.tested,
                (unsigned long long)p.boxes, mine, all);
    EXPECT_EQ(w.points, fluid ? 1024000u : 6640704u);
    EXPECT_EQ(p.points,
              fluid ? 256000u : 409920u); // the box's points: 20 (fluid) or 20 of 320 x-layers
    EXPECT_EQ(mine, fluid ? 256000u : 25920u);
    EXPECT_EQ(p.tested, 0u);
    EXPECT_LE(p.boxes, fluid ? 60u : 632u); // twice the measured
  }
}

TEST(ShapeBounds, HoldAtEveryPointOfTheBox) {
  // Each kind of solid, boxes of every size and shape around and across its surface, with a
  // spread; the distance at random points of each (at its corners, pushed out by the spread,
  // where a bound is nearest, and anywhere within) must lie within.
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
  std::size_t exact = 0;
  for (std::size_t k = 0; k < bounds.size(); ++k)
    for (int trial = 0; trial < 400; ++trial) {
      const Vec3d lo{u(rng), u(rng), u(rng)};
      const Vec3d hi = lo + Vec3d{0.15 * std::abs(u(rng)), 0.15 * std::abs(u(rng)),
                                  trial % 4 == 0 ? 0.0 : 0.15 * std::abs(u(rng))};
      const double spread = trial % 2 ? 0.0 : 0.01 * std::abs(u(rng));
      const DistanceBounds b = bounds.over(k, {lo, hi, spread});
      ASSERT_LE(b.lower, b.upper);
      if (solids.table()[k].kind == ShapeKind::Mesh && std::isfinite(b.lower))
        ++bounded_mesh;
      double least = 1e300, most = -1e300;
      for (int p = 0; p < 60; ++p) {
        std::uniform_real_distribution<double> t(0, 1);
        const Vec3d corner{p & 1 ? hi.x : lo.x, p & 2 ? hi.y : lo.y, p & 4 ? hi.z : lo.z};
        const Vec3d inside{lo.x + t(rng) * (hi.x - lo.x), lo.y + t(rng) * (hi.y - lo.y),
                           lo.z + t(rng) * (hi.z - lo.z)};
        const Vec3d x =
            (p < 16 ? corner : inside) + random_unit(rng) * (p < 32 ? spread : spread * t(rng));
        Vec3d n;
        const double d = solids.table()[k].distance(x, n);
        ASSERT_GE(d, b.lower) << "shape " << k << " box " << trial;
        ASSERT_LE(d, b.upper) << "shape " << k << " box " << trial;
        least = std::min(least, d), most = std::max(most, d);
      }
      // A plane's and a container's bounds are attained (at a corner, pushed by the spread):
      // the samples at the corners reach them within the spread's direction's miss.
      const ShapeKind kind = solids.table()[k].kind;
      if ((kind == ShapeKind::Plane || kind == ShapeKind::Container) && spread == 0) {
        EXPECT_NEAR(least, b.lower, 1e-12) << "shape " << k << " box " << trial;
        if (kind == ShapeKind::Plane) {
          EXPECT_NEAR(most, b.upper, 1e-12) << "shape " << k << " box " << trial;
        }
        ++exact;
      }
    }
  EXPECT_EQ(exact, 400u);        // two exact kinds, half their boxes without a spread
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
  const BoxClassifier classify = [&](const Vec3d& lo, const Vec3d& hi, double e) -> std::uint8_t {
    const Vec3d c = (lo + hi) * 0.5;
    const double r = 0.5 * norm(hi - lo) + e;
    const double d1 = norm(c - c1) - r1, d2 = norm(c - c2) - r2;
    if (d1 + r < 0)
      return 1;
    if (d1 - r >= 0.01 && d2 - r >= 0.01)
      return 0;
    return kSieveMaybe;
  };
  const LatticeSieve sieve(axes, spread, classify);
  std::size_t points = 0, decided = 0;
  // Two slabs and a box inside, as the samplers ask for them: each point's class is its own,
  // whatever box it was asked in.
  const IndexBox whole = sieve.whole();
  std::vector<std::uint8_t> cls, part;
  sieve.classes(whole, cls);
  const IndexBox inner{{3, 5, 7}, {30, 21, 40}};
  sieve.classes(inner, part);
  std::size_t q = 0;
  for (int k = inner.lo[2]; k < inner.hi[2]; ++k)
    for (int j = inner.lo[1]; j < inner.hi[1]; ++j)
      for (int i = inner.lo[0]; i < inner.hi[0]; ++i, ++q) {
        const std::uint8_t a = cls[(std::size_t(k) * whole.hi[1] + j) * whole.hi[0] + i],
                           b = part[q];
        // Both may be undecided or decided differently only where one is kSieveMaybe.
        if (a != kSieveMaybe && b != kSieveMaybe) {
          ASSERT_EQ(a, b);
        }
      }
  q = 0;
  for (int k = 0; k < whole.hi[2]; ++k)
    for (int j = 0; j < whole.hi[1]; ++j)
      for (int i = 0; i < whole.hi[0]; ++i, ++q) {
        const std::uint8_t c = cls[q];
        ++points;
        if (c == kSieveMaybe)
          continue;
        ++decided;
        // A point anywhere within the spread of its lattice position.
        const Vec3d p =
            Vec3d{axes[0][i], axes[1][j], axes[2][k]} + random_unit(rng) * (spread * u(rng));
        const double d1 = norm(p - c1) - r1, d2 = norm(p - c2) - r2;
        if (c == 1)
          ASSERT_LT(d1, 0.0);
        else
          ASSERT_TRUE(d1 >= 0.01 && d2 >= 0.01);
      }
  EXPECT_EQ(points, axes[0].size() * axes[1].size() * axes[2].size());
  EXPECT_GT(decided, points / 2);
}
