// Stitch and yarn geometry (paper §3, Eq. 1, Fig. 1b): the weights, the bonding points of a flat
// patch where the project's corrected Fig. 1b places them (DESIGN §10), continuous yarns that do
// not cut through each other, purl as the mirrored knit, the named patterns, and the yarn phase
// in snapshots (lines in XDMF).
#include "domain/KnitBuilder.hpp"
#include "domain/Simulation.hpp"
#include "domain/Yarns.hpp"
#include "io/Xdmf.hpp"
#include "kernels/knit/Stitch_K.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

using namespace kf;

namespace {

constexpr double kThick = 0.004;

/// A flat patch in the x-y plane, front (layer 0) towards +z: wales along x, courses along y.
Scene patch_scene(int wales, int courses, std::vector<std::string> chart = {"K"}) {
  Scene s;
  s.name = "stitch";
  s.modules = {Module::Knit};
  s.domain.min = {-1, -1, -1};
  s.domain.max = {1, 1, 1};
  s.output.enabled = false;
  s.precision = Precision::Double;
  s.knit.thickness = kThick;
  KnitPiece p;
  p.center = {0, 0, 0};
  p.normal = {0, 0, 1};
  p.u_axis = {1, 0, 0};
  p.width = 0.1 * wales;
  p.height = 0.1 * courses;
  p.wales = wales;
  p.courses = courses;
  p.chart = std::move(chart);
  s.knit.pieces = {p};
  return s;
}

double segment_distance(const Vec3d& p0, const Vec3d& p1, const Vec3d& q0, const Vec3d& q1) {
  // Brute force on a fine parameter grid (exact enough for a lower bound with margin).
  double best = 1e30;
  for (int a = 0; a <= 40; ++a)
    for (int b = 0; b <= 40; ++b)
      best = std::min(best, norm(p0 + (p1 - p0) * (a / 40.0) - q0 - (q1 - q0) * (b / 40.0)));
  return best;
}

} // namespace

TEST(Stitch, EveryBondingPointIsAConvexCombinationOfTheCellCorners) {
  for (int k = 0; k < kBondingPoints; ++k) {
    double w[8], sum = 0;
    stitch_weights(k, w);
    for (double x : w) {
      EXPECT_GE(x, 0.0) << "t" << k + 1;
      sum += x;
    }
    EXPECT_NEAR(sum, 1.0, 1e-15) << "t" << k + 1;
  }
}

// The project's corrected Fig. 1b, not the paper as printed: Eq. 1 as DESIGN §10 reads it, t7's
// and t11's weights over 28 so that each row sums to 1 as the printed ones do not, checked
// against the figure's layout; in cell coordinates (u right along the course, v up along the
// wale, in cell widths) and the side (+1 front layer, -1 back layer). docs/PHYSICS.md holds the
// same table.
TEST(Stitch, AFlatPatchPutsTheBondingPointsWhereTheCorrectedFigure1bDoes) {
  const Scene s = patch_scene(3, 3);
  const KnitMesh mesh = build_knit(s);
  const KnitPieceLayout& L = mesh.pieces[0];
  const double corrected_fig1b[12][3] = {
      {1 / 7., 1, 1}, {3 / 14., 2 / 3., -1}, {11 / 14., 2 / 3., -1}, {6 / 7., 1, 1},
      {0, 1, -1},     {2 / 7., 1, -1},       {5 / 14., 3 / 4., 1},   {1 / 7., 0, 1},
      {1, 1, -1},     {5 / 7., 1, -1},       {9 / 14., 3 / 4., 1},   {6 / 7., 0, 1}};
  const int i = 1, j = 1; // an interior cell
  const Vec3d origin = mesh.x[L.index(1, i, j)];
  const Vec3d m[4] = {mesh.x[L.index(0, i, j)], mesh.x[L.index(0, i + 1, j)],
                      mesh.x[L.index(0, i, j + 1)], mesh.x[L.index(0, i + 1, j + 1)]};
  const Vec3d mb[4] = {mesh.x[L.index(2, i, j)], mesh.x[L.index(2, i + 1, j)],
                       mesh.x[L.index(2, i, j + 1)], mesh.x[L.index(2, i + 1, j + 1)]};
  for (int k = 0; k < 12; ++k) {
    const Vec3d t = bonding_point(k, m, mb, false) - origin;
    EXPECT_NEAR(t.x / 0.1, corrected_fig1b[k][0], 1e-12) << "t" << k + 1;
    EXPECT_NEAR(t.y / 0.1, corrected_fig1b[k][1], 1e-12) << "t" << k + 1;
    EXPECT_NEAR(t.z / (0.5 * kThick), corrected_fig1b[k][2], 1e-12) << "t" << k + 1;
  }
}

// For every named pattern the yarns run without jumps (each step at most a cell diagonal with
// the thickness), one per course plus one, and no two of them touch: loops interlock around each
// other, not through.
TEST(Stitch, YarnsAreContinuousAndDoNotCutThroughEachOther) {
  const std::vector<std::vector<std::string>> charts{{"K"}, {"K", "P"}, {"KP"}, {"KP", "PK"}};
  const char* names[] = {"stockinette", "garter", "rib", "seed"};
  for (std::size_t c = 0; c < charts.size(); ++c) {
    const auto& chart = charts[c];
    const Scene s = patch_scene(4, 3, chart);
    const KnitMesh mesh = build_knit(s);
    const auto yarns = yarn_bonding_points(mesh.x, mesh.pieces[0], chart);
    ASSERT_EQ(yarns.size(), 4u);
    const double longest = std::sqrt(0.1 * 0.1 + 0.1 * 0.1 + kThick * kThick);
    for (const auto& y : yarns) {
      ASSERT_GE(y.size(), 8u);
      for (std::size_t k = 0; k + 1 < y.size(); ++k) {
        EXPECT_GT(norm(y[k + 1] - y[k]), 0.0);
        EXPECT_LE(norm(y[k + 1] - y[k]), longest + 1e-12);
      }
    }
    // Interior yarns: 9 bonding points per stitch and the last t9.
    if (c == 0) {
      EXPECT_EQ(yarns[1].size(), 4u * 9 + 1);
    }
    double closest = 1e30;
    for (std::size_t a = 0; a < yarns.size(); ++a)
      for (std::size_t b = a + 1; b < yarns.size(); ++b)
        for (std::size_t p = 0; p + 1 < yarns[a].size(); ++p)
          for (std::size_t q = 0; q + 1 < yarns[b].size(); ++q)
            closest = std::min(closest, segment_distance(yarns[a][p], yarns[a][p + 1], yarns[b][q],
                                                         yarns[b][q + 1]));
    std::printf("%s: closest approach of two yarns %.3g m = %.2f thickness\n", names[c], closest,
                closest / kThick);
    // Room for yarns a quarter of the fabric thick: they touch nowhere.
    EXPECT_GT(closest, 0.25 * kThick) << names[c];
  }
}

// A purl stitch is the knit stitch mirrored through the thickness.
TEST(Stitch, PurlIsKnitMirroredThroughTheThickness) {
  const Scene knit = patch_scene(3, 3, {"K"}), purl = patch_scene(3, 3, {"P"});
  const KnitMesh mesh = build_knit(knit);
  const auto yk = yarn_bonding_points(mesh.x, mesh.pieces[0], knit.knit.pieces[0].chart);
  const auto yp = yarn_bonding_points(mesh.x, mesh.pieces[0], purl.knit.pieces[0].chart);
  ASSERT_EQ(yk.size(), yp.size());
  for (std::size_t y = 0; y < yk.size(); ++y) {
    ASSERT_EQ(yk[y].size(), yp[y].size());
    for (std::size_t k = 0; k < yk[y].size(); ++k) {
      EXPECT_NEAR(yp[y][k].x, yk[y][k].x, 1e-14);
      EXPECT_NEAR(yp[y][k].y, yk[y][k].y, 1e-14);
      EXPECT_NEAR(yp[y][k].z, -yk[y][k].z, 1e-14);
    }
  }
}

TEST(Stitch, NamedPatternsAreTheirCharts) {
  auto chart_of = [](const std::string& pattern) {
    const Scene s =
        parse_scene("[simulation]\nend_time = 1\nmodules = [\"knit\"]\n[domain]\nmin = [-1,-1,-1]\n"
                    "max = [1,1,1]\n[[knit.piece]]\nshape = \"patch\"\n"
                    "center = [0,0,0]\npattern = \"" +
                        pattern + "\"\n",
                    "<string>");
    return s.knit.pieces[0].chart;
  };
  // Stockinette: all knit. Garter: knit and purl courses. 1x1 rib: knit and purl wales. Seed:
  // a checkerboard.
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) {
      EXPECT_FALSE(is_purl(chart_of("stockinette"), i, j));
      EXPECT_EQ(is_purl(chart_of("garter"), i, j), j % 2 == 1);
      EXPECT_EQ(is_purl(chart_of("rib"), i, j), i % 2 == 1);
      EXPECT_EQ(is_purl(chart_of("seed"), i, j), (i + j) % 2 == 1);
    }
  EXPECT_THROW(
      parse_scene("[simulation]\nend_time = 1\nmodules = [\"knit\"]\n[domain]\nmin = [-1,-1,-1]\n"
                  "max = [1,1,1]\n[[knit.piece]]\nshape = \"patch\"\n"
                  "center = [0,0,0]\nchart = [\"KP\", \"K\"]\n",
                  "<string>"),
      SceneError);
}

// The curves interpolate: every bonding point is a sample, and consecutive samples link up.
TEST(Stitch, CatmullRomYarnsPassThroughTheBondingPoints) {
  const Scene s = patch_scene(2, 2);
  const KnitMesh mesh = build_knit(s);
  const auto yarns = yarn_bonding_points(mesh.x, mesh.pieces[0], {"K"});
  const int samples = 5;
  const YarnLines lines = yarn_lines(yarns, samples);
  std::size_t first = 0;
  for (std::size_t y = 0; y < yarns.size(); ++y) {
    for (std::size_t k = 0; k < yarns[y].size(); ++k)
      EXPECT_LT(norm(lines.x[first + k * samples] - yarns[y][k]), 1e-15);
    const std::size_t n = (yarns[y].size() - 1) * samples + 1;
    for (std::size_t i = first; i < first + n; ++i) {
      EXPECT_EQ(lines.yarn[i], y);
      EXPECT_EQ(lines.segment[i][0], i);
      EXPECT_EQ(lines.segment[i][1], i + 1 < first + n ? i + 1 : i);
    }
    first += n;
  }
  EXPECT_EQ(first, lines.x.size());
}

// Snapshots carry the yarns as a phase whose XDMF topology is lines.
TEST(Stitch, SnapshotsCarryTheYarnsAsLines) {
  Scene s = patch_scene(3, 2);
  s.knit.yarn_samples = 3;
  auto sim = Simulation::create(s, exec::Backend::Cpu);
  const io::Frame fr = sim->frame();
  const io::Phase* yarn = fr.find("yarn");
  ASSERT_NE(yarn, nullptr);
  const std::size_t n = yarn->find("position")->as<double>().size() / 3;
  EXPECT_GT(n, 0u);
  const auto seg = yarn->find("segment")->as<std::uint32_t>();
  ASSERT_EQ(seg.size(), 2 * n);
  for (std::uint32_t v : seg)
    EXPECT_LT(v, n);
  io::SnapshotInfo info;
  info.file = "frame_000000.h5";
  info.phases.push_back(
      {"yarn", n, {{"position", io::DType::F64, 3}, {"segment", io::DType::U32, 2}}});
  const std::string xml = io::xdmf_document({info});
  EXPECT_NE(xml.find("TopologyType=\"Polyline\""), std::string::npos) << xml;
  EXPECT_NE(xml.find("NodesPerElement=\"2\""), std::string::npos);
  s.knit.yarn_samples = 0;
  EXPECT_EQ(Simulation::create(s, exec::Backend::Cpu)->frame().find("yarn"), nullptr);
}

// Wet yarns: a scalar per knit point (the saturation) rides along the yarns with the same Eq. 1
// and Catmull-Rom weights. Both sum to one, so a field linear in position is reproduced exactly
// at every yarn point, for every pattern (mixed-depth points and the bind-off crossing too).
TEST(Stitch, YarnsCarryAScalarWithTheSameWeights) {
  for (const std::vector<std::string>& chart :
       {std::vector<std::string>{"K"}, {"KP", "PK"}, {"K", "P"}}) {
    const Scene s = patch_scene(4, 3, chart);
    const KnitMesh mesh = build_knit(s);
    auto field = [](const Vec3d& q) { return 2.0 + 3.0 * q.x - 1.5 * q.y + 40.0 * q.z; };
    std::vector<double> scalar;
    for (const Vec3d& q : mesh.x)
      scalar.push_back(field(q));
    const auto yarns = yarn_points(mesh.x, &scalar, mesh.pieces[0], chart);
    const YarnLines lines = yarn_lines(yarns, 5);
    ASSERT_EQ(lines.s.size(), lines.x.size());
    ASSERT_GT(lines.x.size(), 100u);
    for (std::size_t i = 0; i < lines.x.size(); ++i)
      ASSERT_NEAR(lines.s[i], field(lines.x[i]), 1e-12) << "yarn point " << i;
    // Without a scalar, the positions are those of yarn_bonding_points.
    const auto plain = yarn_bonding_points(mesh.x, mesh.pieces[0], chart);
    ASSERT_EQ(plain.size(), yarns.size());
    for (std::size_t y = 0; y < plain.size(); ++y) {
      ASSERT_EQ(plain[y].size(), yarns[y].size());
      for (std::size_t k = 0; k < plain[y].size(); ++k)
        EXPECT_EQ(norm(plain[y][k] - yarns[y][k].x), 0.0);
    }
  }
}

// A colour chart colours each yarn where it runs through a stitch: the yarn of course j, at
// wale i, takes the chart's letter (i % columns of row j % rows). Checked against where each
// yarn point lies: its wale from its x (wales 0.1 wide along x), its course from its yarn.
TEST(Stitch, AColourChartColoursTheYarnsByStitch) {
  Scene s = patch_scene(4, 3);
  s.knit.yarn_samples = 4;
  const Vec3d red{1, 0, 0}, blue{0, 0, 1};
  s.knit.pieces[0].colours = {{'A', red}, {'B', blue}};
  s.knit.pieces[0].colour_chart = {"AB", "BA"};
  const io::Frame fr = Simulation::create(s, exec::Backend::Cpu)->frame();
  const io::Phase* yarn = fr.find("yarn");
  ASSERT_NE(yarn, nullptr);
  ASSERT_NE(yarn->find("colour"), nullptr);
  const auto x = yarn->find("position")->as<double>();
  const auto c = yarn->find("colour")->as<float>();
  const auto course = yarn->find("yarn")->as<std::uint32_t>();
  ASSERT_EQ(c.size(), x.size());
  std::size_t checked = 0, seen[2] = {0, 0};
  for (std::size_t p = 0; p < course.size(); ++p) {
    const Vec3d got{c[3 * p], c[3 * p + 1], c[3 * p + 2]};
    ASSERT_TRUE(norm(got - red) == 0 || norm(got - blue) == 0) << "yarn point " << p;
    // Away from a wale's sides (a stitch's loop reaches past them; the colour turns mid-span).
    const double u = (x[3 * p] + 0.2) / 0.1;
    const int wale = int(std::floor(u));
    if (wale < 0 || wale > 3 || std::abs(u - std::round(u)) < 0.3)
      continue;
    const bool a = (wale + int(course[p])) % 2 == 0;
    EXPECT_EQ(norm(got - (a ? red : blue)), 0.0)
        << "yarn point " << p << " (wale " << wale << ", course " << course[p] << ")";
    ++checked;
    ++seen[a ? 0 : 1];
  }
  EXPECT_GT(checked, x.size() / 3 / 3) << "too few yarn points away from the wales' sides";
  EXPECT_GT(seen[0], 0u);
  EXPECT_GT(seen[1], 0u);
  // No chart, no colour field.
  s.knit.pieces[0].colour_chart.clear();
  EXPECT_EQ(Simulation::create(s, exec::Backend::Cpu)->frame().find("yarn")->find("colour"),
            nullptr);
}
