// The fluid's surface on the GPU (render/SurfaceCompute, P6): the compute passes against the
// host's reference (render/FluidSurface) on the same points: the same field within float
// rounding, the same triangles from the same field, and the GPU's own indexed surface of a ball
// closed and consistently oriented through its index list, outward and of the sphere's area; split
// into regions, the parts add up to the whole. Runs through Mesa llvmpipe where there is no GPU.
#include "render/EglContext.hpp"
#include "render/SnapshotRender.hpp"
#include "render/SurfaceCompute.hpp"

#include "support/SurfaceChecks.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <map>
#include <numbers>
#include <random>

using namespace kf;
using kf::test::unmatched_edges;
using render::SurfaceField;

namespace {

constexpr double kDp = 0.01;

/// A ball of lattice points (radius `cells` spacings) and a splash of random drops over it.
std::vector<glm::dvec3> ball_and_splash(int cells, glm::dvec3 c, int drops) {
  std::vector<glm::dvec3> p = kf::test::lattice_ball(cells, c, kDp);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-3 * cells * kDp, 3 * cells * kDp);
  for (int d = 0; d < drops; ++d)
    p.push_back(c + glm::dvec3(u(rng), u(rng), u(rng) + 4 * cells * kDp));
  return p;
}

/// A snapshot frame holding only these points, as its fluid's positions.
io::Frame fluid_frame(const std::vector<glm::dvec3>& p) {
  std::vector<float> x;
  for (const auto& q : p)
    x.insert(x.end(), {float(q.x), float(q.y), float(q.z)});
  io::Frame frame;
  frame.phases.push_back({"fluid", {io::Field::from("position", x, 3)}});
  return frame;
}

const char* name(SurfaceField f) {
  return f == SurfaceField::Naive ? "naive" : "weighted";
}

/// The mesh's triangles as sorted rows of their vertices' coordinates, for comparing two lists
/// of the same triangles in any order.
std::vector<std::array<float, 9>> triangle_rows(const render::SurfaceMesh& m) {
  std::vector<std::array<float, 9>> rows;
  for (std::size_t t = 0; t + 2 < m.index.size(); t += 3) {
    std::array<float, 9> r;
    for (int v = 0; v < 3; ++v)
      for (int a = 0; a < 3; ++a)
        r[std::size_t(3 * v + a)] = m.position[m.index[t + std::size_t(v)]][a];
    rows.push_back(r);
  }
  std::sort(rows.begin(), rows.end());
  return rows;
}

/// The mesh with vertices of equal bits made one (a vertex a grid edge: a list without repeats
/// keeps its size).
render::SurfaceMesh welded(const render::SurfaceMesh& m) {
  render::SurfaceMesh w;
  std::map<std::array<std::uint32_t, 3>, std::uint32_t> id;
  for (std::uint32_t i : m.index) {
    std::array<std::uint32_t, 3> key;
    std::memcpy(key.data(), &m.position[i], sizeof key);
    const auto [it, fresh] = id.try_emplace(key, std::uint32_t(w.position.size()));
    if (fresh) {
      w.position.push_back(m.position[i]);
      w.normal.push_back(m.normal[i]);
    }
    w.index.push_back(it->second);
  }
  return w;
}

class SurfaceOnGpu : public ::testing::Test {
protected:
  render::EglContext context;
};

} // namespace

TEST_F(SurfaceOnGpu, TheFieldIsTheHostsWithinFloatRounding) {
  render::SurfaceCompute gpu;
  const auto p = ball_and_splash(8, {0.3, -0.2, 0.5}, 300);
  for (SurfaceField f : {SurfaceField::Naive, SurfaceField::Weighted}) {
    render::SurfaceOptions opt;
    opt.field = f;
    opt.spacing = kDp;
    const render::ScalarGrid host = render::surface_field(p, opt);
    gpu.extract(p, opt);
    const render::ScalarGrid dev = gpu.read_field();
    ASSERT_EQ(dev.n, host.n) << name(f);
    ASSERT_EQ(dev.value.size(), host.value.size());
    double worst = 0;
    std::size_t nan = 0;
    for (std::size_t v = 0; v < host.value.size(); ++v) {
      nan += !std::isfinite(dev.value[v]);
      worst = std::max(worst, double(std::abs(dev.value[v] - host.value[v])));
    }
    // Float sums of ~1000 terms against the host's double. Weighted: a distance of a few dp from
    // offsets over a box of 0.5 m, measured 8.1e-6 m (at a vertex where the weights nearly
    // vanish: a far drop's edge); naive: a sum of order 1, measured 1.2e-6.
    const double bound = f == SurfaceField::Weighted ? 2e-5 : 5e-6;
    std::printf("%-8s field on %zu vertices: largest |gpu - host| %.3g (bound %.3g)\n", name(f),
                host.value.size(), worst, bound);
    EXPECT_EQ(nan, 0u) << name(f);
    EXPECT_LT(worst, bound) << name(f);
  }
}

TEST_F(SurfaceOnGpu, MarchingCubesGivesTheHostsTrianglesFromTheSameField) {
  render::SurfaceCompute gpu;
  const auto p = ball_and_splash(8, {0.3, -0.2, 0.5}, 300);
  render::SurfaceOptions opt;
  opt.spacing = kDp;
  const render::ScalarGrid field = render::surface_field(p, opt);
  const auto host = triangle_rows(render::marching_cubes(field));
  gpu.polygonise(field);
  const auto dev = triangle_rows(gpu.read_mesh());
  ASSERT_EQ(dev.size(), host.size());
  ASSERT_GT(host.size(), 1000u);
  // Each host triangle against the GPU's nearest (by centroid, in buckets of a grid cell), each
  // GPU triangle used once.
  auto bucket = [&](const std::array<float, 9>& t) {
    std::array<long, 3> b;
    for (std::size_t a = 0; a < 3; ++a)
      b[a] = long(std::floor((t[a] + t[3 + a] + t[6 + a]) / 3 / field.cell));
    return b;
  };
  std::map<std::array<long, 3>, std::vector<std::size_t>> buckets;
  for (std::size_t t = 0; t < dev.size(); ++t)
    buckets[bucket(dev[t])].push_back(t);
  std::vector<bool> used(dev.size(), false);
  double worst = 0;
  std::size_t unmatched = 0;
  for (const auto& h : host) {
    const auto b = bucket(h);
    double best = 1e30;
    std::size_t pick = dev.size();
    for (long i = -1; i <= 1; ++i)
      for (long j = -1; j <= 1; ++j)
        for (long k = -1; k <= 1; ++k) {
          const auto it = buckets.find({b[0] + i, b[1] + j, b[2] + k});
          if (it == buckets.end())
            continue;
          for (std::size_t t : it->second) {
            double d = 0;
            for (std::size_t c = 0; c < 9; ++c)
              d = std::max(d, double(std::abs(dev[t][c] - h[c])));
            if (!used[t] && d < best) {
              best = d;
              pick = t;
            }
          }
        }
    if (pick == dev.size()) {
      ++unmatched;
      continue;
    }
    used[pick] = true;
    worst = std::max(worst, best);
  }
  EXPECT_EQ(unmatched, 0u);
  // The same interpolation in float against the host's double: a few ulps of coordinates of
  // about 0.5 m (6e-8 each); measured 1.2e-7.
  std::printf("%zu triangles, largest vertex difference %.3g m\n", host.size(), worst);
  EXPECT_LT(worst, 5e-7);
}

TEST_F(SurfaceOnGpu, ABallIsClosedOutwardAndHasTheSpheresArea) {
  render::SurfaceCompute gpu;
  const glm::dvec3 centre(0.3, -0.2, 0.5);
  const auto p = ball_and_splash(10, centre, 0);
  const double r = std::cbrt(3.0 * double(p.size()) / (4 * std::numbers::pi)) * kDp;
  for (SurfaceField f : {SurfaceField::Naive, SurfaceField::Weighted}) {
    render::SurfaceOptions opt;
    opt.field = f;
    opt.spacing = kDp;
    const std::size_t indices = gpu.extract(p, opt);
    ASSERT_EQ(indices % 3, 0u);
    // Closed and oriented through the GPU's own index list: every edge's two triangles name
    // the same two vertices.
    const auto mesh = gpu.read_mesh();
    ASSERT_EQ(mesh.position.size(), gpu.vertex_count());
    ASSERT_LT(*std::max_element(mesh.index.begin(), mesh.index.end()), mesh.position.size());
    EXPECT_EQ(mesh.position.size(), welded(mesh).position.size()) << "a vertex listed twice";
    ASSERT_GT(mesh.triangles(), 1000u) << name(f);
    EXPECT_EQ(unmatched_edges(mesh), 0u) << name(f) << ": open or inconsistently oriented";
    double worst = 1, volume = 0;
    for (std::size_t v = 0; v < mesh.position.size(); ++v)
      worst = std::min(worst, glm::dot(glm::dvec3(mesh.normal[v]),
                                       glm::normalize(glm::dvec3(mesh.position[v]) - centre)));
    for (std::size_t t = 0; t < mesh.index.size(); t += 3)
      volume += glm::dot(glm::dvec3(mesh.position[mesh.index[t]]) - centre,
                         glm::cross(glm::dvec3(mesh.position[mesh.index[t + 1]]) - centre,
                                    glm::dvec3(mesh.position[mesh.index[t + 2]]) - centre)) /
                6;
    const double area = mesh.area(), sphere = 4 * std::numbers::pi * r * r;
    std::printf("%-8s GPU ball: %zu triangles, area %+.2f%% of the sphere's, normals within "
                "%.1f deg of radial\n",
                name(f), mesh.triangles(), 100 * (area / sphere - 1),
                std::acos(worst) * 180 / std::numbers::pi);
    EXPECT_NEAR(area, sphere, 0.05 * sphere) << name(f); // the bound
    EXPECT_GT(volume, 0) << name(f) << ": the triangles face inward";
    EXPECT_GT(worst, std::cos(30 * std::numbers::pi / 180)) << name(f); // normals point out
  }
}

TEST_F(SurfaceOnGpu, RegionsSplitTheSurfaceWithoutLossOrOverlap) {
  render::SurfaceCompute gpu;
  const auto p = ball_and_splash(8, {0.3, -0.2, 0.5}, 300);
  render::SurfaceOptions opt;
  opt.spacing = kDp;
  gpu.extract(p, opt);
  const auto whole = triangle_rows(gpu.read_mesh());
  for (int parts : {2, 3}) {
    std::vector<std::array<float, 9>> joined;
    for (const render::Region& r : render::kd_split(p, parts)) {
      gpu.extract(p, opt, &r);
      const auto part = triangle_rows(gpu.read_mesh());
      EXPECT_GT(part.size(), 0u);
      joined.insert(joined.end(), part.begin(), part.end());
    }
    std::sort(joined.begin(), joined.end());
    EXPECT_EQ(joined, whole) << parts << " parts";
  }
}

TEST(SurfaceOnGpuPicture, ThePictureIsTheHostSurfacesPicture) {
  // A splash drawn with the surface from the GPU's passes and from the host's: the same
  // triangles to float rounding, so the same picture but for a few edge pixels.
  const io::Frame frame = fluid_frame(ball_and_splash(8, {0.3, -0.2, 0.5}, 300));
  std::vector<io::RgbaImage> pictures;
  for (bool gpu : {true, false}) {
    render::SnapshotStyle s;
    s.width = 320;
    s.height = 240;
    s.geometry_on_gpu = gpu;
    render::SnapshotRenderer r(s);
    pictures.push_back(r.draw(frame, r.frame_camera(frame)));
    EXPECT_GT(r.last_triangles(), 10000u);
  }
  std::size_t differ = 0, covered = 0;
  int worst = 0;
  for (std::size_t i = 0; i < pictures[0].pixels.size(); i += 4) {
    int d = 0;
    for (std::size_t c = 0; c < 3; ++c)
      d = std::max(d, std::abs(int(pictures[0].pixels[i + c]) - int(pictures[1].pixels[i + c])));
    differ += d > 2;
    worst = std::max(worst, d);
    covered += pictures[1].pixels[i] != 255 || pictures[1].pixels[i + 1] != 255;
  }
  std::printf("%zu of %zu pixels differ by more than 2 levels (largest %d), %zu covered\n", differ,
              pictures[0].pixels.size() / 4, worst, covered);
  EXPECT_GT(covered, 5000u);
  // A triangle's edge moved by 1e-7 m can flip a pixel's centre from one triangle to the next:
  // measured 0 such pixels; 0.1% of the covered ones allowed.
  EXPECT_LE(differ, covered / 1000);
}

TEST(SurfaceOnGpuPicture, ACoarserCellDrawsFewerTriangles) {
  // [render] surface_cell reaches the surface's grid: a cell twice as coarse lays a quarter of
  // the triangles over the same area (a closed surface's triangles go as its area over a cell
  // squared).
  const io::Frame frame = fluid_frame(ball_and_splash(8, {0.3, -0.2, 0.5}, 0));
  std::vector<double> triangles;
  for (double cell : {0.5, 1.0}) {
    render::SnapshotStyle s;
    s.width = 64;
    s.height = 48;
    s.surface_cell = cell;
    render::SnapshotRenderer r(s);
    r.draw(frame, r.frame_camera(frame));
    triangles.push_back(double(r.last_triangles()));
  }
  std::printf("triangles: %.0f at 0.5 dp, %.0f at 1 dp\n", triangles[0], triangles[1]);
  // Measured 3.95 (the ball's edges cut where the grid meets them); 5% allowed.
  EXPECT_NEAR(triangles[0] / triangles[1], 4.0, 0.2);
}
