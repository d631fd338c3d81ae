// Knitted pieces from OBJ quad meshes (free-form garments): a flat grid OBJ gives exactly the
// patch's points, masses, springs and volume cells; a cylinder has the fabric's mass and its
// layers along the outward normal; irregular vertices get the documented bend springs; an
// undeformed mesh piece is in equilibrium; and the example garment scene runs.
#include "domain/KnitBuilder.hpp"
#include "domain/KnitMeshPiece.hpp"
#include "domain/Simulation.hpp"
#include "domain/Yarns.hpp"
#include "support/TestPaths.hpp"

#include "support/KnitChecks.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <numbers>
#include <sstream>
#include <tuple>

using namespace kf;

namespace {

Scene knit_scene() {
  return test::knit_only_scene("knit_mesh");
}

KnitPiece mesh_piece(const std::string& obj_text, double scale = 1, Vec3d translate = {0, 0, 0}) {
  KnitPiece p;
  p.shape = KnitShape::Mesh;
  p.scale = scale;
  p.translate = translate;
  p.mesh = std::make_shared<const KnitQuadMesh>(
      make_knit_quad_mesh(io::parse_obj(obj_text, "t.obj"), scale, translate));
  return p;
}

/// A flat nu x nv grid of quads in the z = 0 plane, spacing a along x and b along y, centred on
/// the origin, wound counter-clockwise seen from +z; vertex (i, j) is number j * (nu + 1) + i,
/// the patch's order, so point indices of the two pieces coincide.
std::string grid_obj(int nu, int nv, double a, double b) {
  std::ostringstream os;
  os.precision(17);
  for (int j = 0; j <= nv; ++j)
    for (int i = 0; i <= nu; ++i)
      os << "v " << i * a - 0.5 * nu * a << " " << j * b - 0.5 * nv * b << " 0\n";
  auto id = [&](int i, int j) { return j * (nu + 1) + i + 1; };
  for (int j = 0; j < nv; ++j)
    for (int i = 0; i < nu; ++i)
      os << "f " << id(i, j) << " " << id(i + 1, j) << " " << id(i + 1, j + 1) << " "
         << id(i, j + 1) << "\n";
  return os.str();
}

/// A tube of n wales around and m courses along z, radius r and length h, centred on the origin:
/// the grid counterpart of cylinder_obj(n, m, r, h) translated by -h/2.
KnitPiece tube_piece(int n, int m, double r, double h) {
  KnitPiece p;
  p.shape = KnitShape::Tube;
  p.center = {0, 0, 0};
  p.normal = {0, 0, 1};
  p.u_axis = {1, 0, 0};
  p.circumference = 2 * std::numbers::pi * r;
  p.length = h;
  p.wales = n;
  p.courses = m;
  return p;
}

/// An open cylinder about z of n quads around and m along, radius r and length h, wound outward.
std::string cylinder_obj(int n, int m, double r, double h) {
  std::ostringstream os;
  os.precision(17);
  for (int j = 0; j <= m; ++j)
    for (int i = 0; i < n; ++i) {
      const double th = 2 * std::numbers::pi * i / n;
      os << "v " << r * std::cos(th) << " " << r * std::sin(th) << " " << h * j / m << "\n";
    }
  auto id = [&](int i, int j) { return j * n + (i % n) + 1; };
  for (int j = 0; j < m; ++j)
    for (int i = 0; i < n; ++i)
      os << "f " << id(i, j) << " " << id(i + 1, j) << " " << id(i + 1, j + 1) << " "
         << id(i, j + 1) << "\n";
  return os.str();
}

/// A pentagon cut into five quads around its centre (an interior vertex of valence 5), the
/// centre lifted by `lift` so the piece is not flat.
std::string pentagon_obj(double r, double lift) {
  std::ostringstream os;
  os.precision(17);
  os << "v 0 0 " << lift << "\n"; // 1: centre
  for (int k = 0; k < 5; ++k) {   // 2..6: corners
    const double th = 2 * std::numbers::pi * k / 5;
    os << "v " << r * std::cos(th) << " " << r * std::sin(th) << " 0\n";
  }
  for (int k = 0; k < 5; ++k) { // 7..11: midpoints of the sides
    const double t0 = 2 * std::numbers::pi * k / 5, t1 = 2 * std::numbers::pi * (k + 1) / 5;
    os << "v " << 0.5 * r * (std::cos(t0) + std::cos(t1)) << " "
       << 0.5 * r * (std::sin(t0) + std::sin(t1)) << " 0\n";
  }
  for (int k = 0; k < 5; ++k) // centre, midpoint k-1, corner k, midpoint k: counter-clockwise
    os << "f 1 " << 7 + (k + 4) % 5 << " " << 2 + k << " " << 7 + k << "\n";
  return os.str();
}

// Springs as a multiset of (pair, kind) -> (rest, k, c), for comparing two builds.
using SpringKey = std::tuple<std::uint32_t, std::uint32_t, int>;
std::multimap<SpringKey, std::array<double, 3>> spring_set(const KnitMesh& m) {
  std::multimap<SpringKey, std::array<double, 3>> out;
  for (const Spring& s : m.springs)
    out.insert({{std::min(s.i, s.j), std::max(s.i, s.j), int(s.kind)}, {s.rest, s.k, s.c}});
  return out;
}

// Volume cells keyed by (apex, o, the two sides in increasing order) -> (signed rest volume for
// that order, k): swapping the sides negates V and V0, which leaves the energy unchanged.
using CellKey = std::array<std::uint32_t, 4>;
std::multimap<CellKey, std::array<double, 2>> cell_set(const KnitMesh& m) {
  std::multimap<CellKey, std::array<double, 2>> out;
  for (const VolumeCell& c : m.volumes) {
    const bool swap = c.point[2] > c.point[3];
    out.insert({{c.point[0], c.point[1], std::min(c.point[2], c.point[3]),
                 std::max(c.point[2], c.point[3])},
                {swap ? -c.rest_volume : c.rest_volume, c.k}});
  }
  return out;
}

bool close(double x, double y, double rel) {
  return std::fabs(x - y) <= rel * std::max(std::fabs(x), std::fabs(y)) + 1e-300;
}

/// Compares two builds: the same points (to 1e-12 of their size), the same spring pairs and kinds
/// and the same volume cells (as multisets); rest lengths and cell volumes to 1e-12, stiffness,
/// damping and mass to `rel`. Returns the springs' and cells' count.
std::pair<std::size_t, std::size_t> expect_same_build(const KnitMesh& a, const KnitMesh& b,
                                                      double rel) {
  EXPECT_EQ(a.x.size(), b.x.size());
  if (a.x.size() != b.x.size())
    return {0, 0};
  const double tol = 1e-12;
  for (std::size_t i = 0; i < a.x.size(); ++i) {
    EXPECT_LT(norm(a.x[i] - b.x[i]), tol * (1 + norm(a.x[i]))) << "point " << i;
    EXPECT_TRUE(close(a.m[i], b.m[i], rel)) << "mass " << i << ": " << a.m[i] << " vs " << b.m[i];
    EXPECT_EQ(a.layer[i], b.layer[i]);
  }
  const auto sa = spring_set(a), sb = spring_set(b);
  EXPECT_EQ(sa.size(), sb.size());
  std::array<int, kSpringKinds> per_kind{};
  for (auto ia = sa.begin(), ib = sb.begin(); ia != sa.end() && ib != sb.end(); ++ia, ++ib) {
    if (ia->first != ib->first) {
      ADD_FAILURE() << "spring pair/kind differs: " << std::get<0>(ia->first) << "-"
                    << std::get<1>(ia->first) << " kind " << std::get<2>(ia->first) << " vs "
                    << std::get<0>(ib->first) << "-" << std::get<1>(ib->first) << " kind "
                    << std::get<2>(ib->first);
      break;
    }
    for (int k = 0; k < 3; ++k)
      EXPECT_TRUE(close(ia->second[k], ib->second[k], k == 0 ? tol : rel))
          << "spring " << std::get<0>(ia->first) << "-" << std::get<1>(ia->first) << " kind "
          << std::get<2>(ia->first) << " field " << k << ": " << ia->second[k] << " vs "
          << ib->second[k];
    ++per_kind[std::get<2>(ia->first)];
  }
  for (int k = 0; k < kSpringKinds; ++k)
    EXPECT_GT(per_kind[k], 0) << "no spring of kind " << k << ": the comparison would be empty";
  const auto ca = cell_set(a), cb = cell_set(b);
  EXPECT_EQ(ca.size(), cb.size());
  EXPECT_GT(ca.size(), 0u);
  for (auto ia = ca.begin(), ib = cb.begin(); ia != ca.end() && ib != cb.end(); ++ia, ++ib) {
    if (ia->first != ib->first) {
      ADD_FAILURE() << "cell points differ";
      break;
    }
    EXPECT_TRUE(close(ia->second[0], ib->second[0], tol)) << "cell rest volume";
    EXPECT_TRUE(close(ia->second[1], ib->second[1], rel)) << "cell stiffness";
  }
  return {sb.size(), cb.size()};
}

/// The mesh piece built from a grid OBJ against the patch of the same grid.
void expect_same_as_patch(int nu, int nv, double width, double height, double scale,
                          const Vec3d& translate) {
  Scene patch = knit_scene(), mesh = knit_scene();
  KnitPiece p;
  p.center = translate;
  p.width = width;
  p.height = height;
  p.wales = nu;
  p.courses = nv;
  patch.knit.pieces = {p};
  mesh.knit.pieces = {
      mesh_piece(grid_obj(nu, nv, width / nu / scale, height / nv / scale), scale, translate)};
  const KnitMesh a = build_knit(patch), b = build_knit(mesh);
  const auto [springs, cells] = expect_same_build(a, b, 1e-12);
  ASSERT_EQ(b.pieces.size(), 1u);
  EXPECT_FALSE(b.pieces[0].grid);
  EXPECT_EQ(b.pieces[0].quads.size(), std::size_t(nu * nv));
  EXPECT_EQ(b.pieces[0].index(2, 3, 0), std::uint32_t(2 * (nu + 1) * (nv + 1) + 3));
  std::printf("grid %dx%d (a %.4g, b %.4g): %zu points, %zu springs, %zu cells identical\n", nu, nv,
              width / nu, height / nv, b.x.size(), springs, cells);
}

} // namespace

TEST(KnitMeshPiece, FlatGridObjGivesThePatch) {
  expect_same_as_patch(5, 5, 0.2, 0.2, 1.0, {0, 0, 0});
}

TEST(KnitMeshPiece, FlatGridObjGivesThePatchWithOtherSpacingsScaledAndMoved) {
  // a = 0.05, b = 0.04; the OBJ at half size, scale 2 and translate place it like the patch.
  expect_same_as_patch(6, 3, 0.3, 0.12, 2.0, {0.1, -0.2, 0.3});
  expect_same_as_patch(1, 4, 0.05, 0.3, 1.0, {0, 0, 0}); // one quad across: no bend along u
}

TEST(KnitMeshPiece, CylinderHasTheFabricsMassAndLayersAlongTheOutwardNormal) {
  const int n = 16, m = 5;
  const double r = 0.1, h = 0.3;
  Scene s = knit_scene();
  s.knit.pieces = {mesh_piece(cylinder_obj(n, m, r, h))};
  const KnitMesh mesh = build_knit(s);
  const std::size_t nv = std::size_t(n) * (m + 1);
  ASSERT_EQ(mesh.x.size(), 3 * nv);
  double mass = 0;
  for (double x : mesh.m)
    mass += x;
  const double area = n * 2 * r * std::sin(std::numbers::pi / n) * h; // the polygon's
  EXPECT_NEAR(mass, s.knit.mass_per_area * area, 1e-12 * mass);
  const double t = s.knit.thickness;
  double worst = 0;
  for (std::size_t v = 0; v < nv; ++v) {
    const Vec3d mid = mesh.x[nv + v];
    const Vec3d radial = Vec3d{mid.x, mid.y, 0} * (1.0 / std::hypot(mid.x, mid.y));
    EXPECT_NEAR(std::hypot(mid.x, mid.y), r, 1e-12);
    worst = std::max({worst, norm(mesh.x[v] - (mid + radial * (0.5 * t))),
                      norm(mesh.x[2 * nv + v] - (mid - radial * (0.5 * t)))});
  }
  EXPECT_LT(worst, 1e-12) << "front/back not at +-t/2 along the outward normal";
  // Bend springs: one around through every vertex, one along through every inner ring.
  // Each spans two steps straight on: in the middle layer a chord of two steps around, or two
  // rings along.
  const double around = 2 * r * std::sin(2 * std::numbers::pi / n), along = 2 * h / m;
  std::size_t bends = 0;
  for (const Spring& sp : mesh.springs) {
    if (sp.kind != SpringKind::Bend)
      continue;
    ++bends;
    if (sp.i >= nv && sp.i < 2 * nv) {
      EXPECT_TRUE(std::fabs(sp.rest - around) < 1e-12 || std::fabs(sp.rest - along) < 1e-12)
          << "bend " << sp.i << "-" << sp.j << " of length " << sp.rest;
    }
  }
  EXPECT_EQ(bends, 3u * (std::size_t(n) * (m + 1) + std::size_t(n) * (m - 1)));
}

// A cylinder OBJ against the tube of the same grid: the same points, springs and cells on a
// curved, closed-around surface. The tube's spacing around is the arc, the mesh's the chord, so
// stiffnesses and masses differ by at most that ratio (0.16% at 32 around).
TEST(KnitMeshPiece, CylinderObjGivesTheTubeUpToChordVersusArc) {
  const int n = 32, m = 8;
  const double r = 0.06, h = 0.2;
  Scene tube = knit_scene(), mesh = knit_scene();
  tube.knit.pieces = {tube_piece(n, m, r, h)};
  mesh.knit.pieces = {mesh_piece(cylinder_obj(n, m, r, h), 1, {0, 0, -0.5 * h})};
  const double arc_over_chord = (std::numbers::pi / n) / std::sin(std::numbers::pi / n);
  const auto [springs, cells] =
      expect_same_build(build_knit(tube), build_knit(mesh), 2 * (arc_over_chord - 1));
  std::printf("cylinder %dx%d: %zu springs, %zu cells as the tube's (stiffness within %.2f%%)\n", n,
              m, springs, cells, 200 * (arc_over_chord - 1));
}

/// Yarns of two builds agree point for point (to 1e-12 of the point's size).
void expect_same_yarns(const Scene& a, const Scene& b) {
  const KnitMesh ma = build_knit(a), mb = build_knit(b);
  const auto ya = yarn_bonding_points(ma.x, ma.pieces[0], a.knit.pieces[0].chart);
  const auto yb = yarn_bonding_points(mb.x, mb.pieces[0], b.knit.pieces[0].chart);
  ASSERT_EQ(ya.size(), yb.size());
  std::size_t points = 0;
  for (std::size_t y = 0; y < ya.size(); ++y) {
    ASSERT_EQ(ya[y].size(), yb[y].size()) << "yarn " << y;
    for (std::size_t k = 0; k < ya[y].size(); ++k)
      ASSERT_LT(norm(ya[y][k] - yb[y][k]), 1e-12 * (1 + norm(ya[y][k])))
          << "yarn " << y << " point " << k;
    points += ya[y].size();
  }
  EXPECT_GT(points, 0u);
  std::printf("%zu yarns, %zu bonding points identical\n", ya.size(), points);
}

// Yarns of a mesh piece follow strips of quads; on a grid OBJ (open) and a cylinder OBJ (closed
// strips) they are the patch's and the tube's yarns.
TEST(KnitMeshPiece, GridAndCylinderObjsGiveThePatchsAndTheTubesYarns) {
  {
    const int nu = 6, nv = 4;
    const double w = 0.3, h = 0.2;
    Scene patch = knit_scene(), mesh = knit_scene();
    KnitPiece p;
    p.center = {0, 0, 0};
    p.width = w;
    p.height = h;
    p.wales = nu;
    p.courses = nv;
    patch.knit.pieces = {p};
    mesh.knit.pieces = {mesh_piece(grid_obj(nu, nv, w / nu, h / nv))};
    expect_same_yarns(patch, mesh);
  }
  {
    const int n = 16, m = 5;
    const double r = 0.05, h = 0.15;
    Scene tube = knit_scene(), mesh = knit_scene();
    tube.knit.pieces = {tube_piece(n, m, r, h)};
    mesh.knit.pieces = {mesh_piece(cylinder_obj(n, m, r, h), 1, {0, 0, -0.5 * h})};
    expect_same_yarns(tube, mesh);
  }
}

// Where the quads' frames turn (the pentagon's kites meet at a valence-5 vertex, each one's left
// side the next one's bottom), strips end: every quad's legs and head arc are still drawn, once.
TEST(KnitMeshPiece, YarnsStopWhereTheQuadsFrameTurns) {
  Scene s = knit_scene();
  s.knit.pieces = {mesh_piece(pentagon_obj(0.1, 0.02))};
  const KnitMesh mesh = build_knit(s);
  const auto yarns = yarn_bonding_points(mesh.x, mesh.pieces[0], s.knit.pieces[0].chart);
  ASSERT_EQ(yarns.size(), 10u); // five strips of one quad (legs), five of their arcs
  for (std::size_t y = 0; y < 5; ++y)
    EXPECT_EQ(yarns[y].size(), 8u) << "legs t5..t8, t12..t9";
  for (std::size_t y = 5; y < 10; ++y)
    EXPECT_EQ(yarns[y].size(), 4u) << "arc t1..t4";
  for (const auto& y : yarns)
    for (std::size_t k = 0; k + 1 < y.size(); ++k)
      EXPECT_LT(norm(y[k + 1] - y[k]), 0.1) << "a jump across the piece";
}

TEST(KnitMeshPiece, IrregularVertexGetsHalfStiffnessBendsAcrossIt) {
  Scene s = knit_scene();
  s.knit.pieces = {mesh_piece(pentagon_obj(0.1, 0.0))};
  const KnitMesh mesh = build_knit(s);
  const std::uint32_t nv = 11;
  // Per layer: 5 through the valence-5 centre (midpoints two apart, half stiffness) and 5 along
  // the boundary through each side's midpoint; none through the corners (one quad each).
  std::vector<const Spring*> through_centre, along_sides;
  for (const Spring& sp : mesh.springs) {
    if (sp.kind != SpringKind::Bend || sp.i >= nv || sp.j >= nv)
      continue;
    const bool mids = sp.i >= 6 && sp.j >= 6; // both midpoints (0-based 6..10)
    (mids ? through_centre : along_sides).push_back(&sp);
  }
  ASSERT_EQ(through_centre.size(), 5u);
  ASSERT_EQ(along_sides.size(), 5u);
  // Reference: B * width / (a1 + a2) / 3 * 1/2, a the centre-midpoint distance, width the mean of
  // the two quads' other sides (halved per quad, summed over the two quads of the edge).
  const double r = 0.1, side = 2 * r * std::sin(std::numbers::pi / 5);
  const double apothem = r * std::cos(std::numbers::pi / 5);
  // Each quad is a kite (centre, midpoint, corner, midpoint): beside a centre-midpoint edge lie
  // the other centre-midpoint edge and a half side.
  const double other = 0.5 * (apothem + 0.5 * side), width = 2 * 0.5 * other;
  const double k_ref = 0.5 * s.knit.bend * width / (2 * apothem) / 3;
  for (const Spring* sp : through_centre)
    EXPECT_NEAR(sp->k, k_ref, 1e-12 * k_ref);
}

TEST(KnitMeshPiece, UndeformedCurvedPieceIsInEquilibrium) {
  for (const std::string& obj : {cylinder_obj(12, 4, 0.08, 0.2), pentagon_obj(0.1, 0.03)}) {
    Scene s = knit_scene();
    s.gravity = {0, 0, 0};
    s.knit.pieces = {mesh_piece(obj)};
    auto sim = Simulation::create(s, exec::Backend::Cpu);
    const auto a = sim->frame().find("knit")->find("acceleration")->as<double>();
    // Scale: a compression spring's pull at 1% strain on the lightest point.
    const KnitMesh mesh = build_knit(s);
    double kmax = 0, mmin = 1e300;
    for (const Spring& sp : mesh.springs)
      kmax = std::max(kmax, sp.k);
    for (double m : mesh.m)
      mmin = std::min(mmin, m);
    const double scale = kmax * 0.01 * s.knit.thickness / mmin;
    double worst = 0;
    for (double x : a)
      worst = std::max(worst, std::fabs(x));
    std::printf("undeformed mesh piece: largest acceleration %.2e m/s^2 (scale %.2e)\n", worst,
                scale);
    EXPECT_LT(worst, 1e-9 * scale);
  }
}

TEST(KnitMeshPiece, BadMeshesAreRejectedWithTheirPlace) {
  struct Bad {
    const char* obj;
    const char* says;
  };
  const std::string quad = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n";
  const Bad bad[] = {
      {"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "is not a quad mesh: the face on t.obj:4 has 3"},
      {"", "has no faces"},
      {"v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 5 5 5\nf 1 2 3 4\n", "vertex 5 belongs to no face"},
      {"v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 2 0 0\nv 2 1 0\nf 1 2 3 4\nf 3 6 5 2\n",
       "is not consistently oriented: edge (2, 3) runs the same way in its faces on t.obj:7 and "
       "t.obj:8"},
      {"v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 2 0 0\nv 2 1 0\nv 1 0 1\nv 1 1 1\n"
       "f 1 2 3 4\nf 3 2 5 6\nf 3 2 7 8\n",
       "is not a manifold: edge (2, 3) belongs to 3 faces (t.obj:9, t.obj:10, t.obj:11)"},
      // Two quads touching at vertex 3 only: a bow tie.
      {"v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 2 1 0\nv 2 2 0\nv 1 2 0\nf 1 2 3 4\nf 3 5 6 7\n",
       "is not a manifold at vertex 3"},
      {"v 0 0 0\nv 1 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3 4\n", "the face on t.obj:5 is degenerate"},
      {"v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 1\n", "uses vertex 1 twice"},
  };
  for (const Bad& b : bad) {
    std::string msg;
    try {
      make_knit_quad_mesh(io::parse_obj(b.obj, "t.obj"), 1, {0, 0, 0});
    } catch (const Error& e) {
      msg = e.what();
    }
    EXPECT_NE(msg.find(b.says), std::string::npos) << "got: '" << msg << "'";
    EXPECT_EQ(msg.rfind("mesh 't.obj'", 0), 0u) << msg;
  }
}

// The example scene (every scene in scenes/ must run): a sleeve hung by its top ring.
TEST(KnitMeshPiece, GarmentSceneRuns) {
  Scene s = load_scene((test::source_dir() / "scenes" / "garment.toml").string());
  ASSERT_EQ(s.knit.pieces.size(), 1u);
  ASSERT_EQ(s.knit.pieces[0].shape, KnitShape::Mesh);
  s.output.enabled = false;
  s.end_time = std::min(s.end_time, 0.2);
  auto sim = Simulation::create(s, exec::Backend::Cpu);
  const Diagnostics d0 = sim->diagnostics();
  while (sim->time() < s.end_time)
    sim->step(s.end_time);
  const Diagnostics d = sim->diagnostics();
  std::printf("garment.toml to t = %.2f s: %zu points, %llu steps, kinetic %.3e J, elastic %.3e J, "
              "self contacts %llu\n",
              sim->time(), d.knit, static_cast<unsigned long long>(sim->steps()),
              d.knit_kinetic_energy, d.knit_elastic_energy,
              static_cast<unsigned long long>(d.knit_self_contacts));
  EXPECT_TRUE(std::isfinite(d.knit_kinetic_energy));
  EXPECT_LT(d.knit_potential_energy, d0.knit_potential_energy) << "the cuff did not sag";
  EXPECT_GT(d.knit_elastic_energy, 0);
  // The sleeve's quads run in rings: its yarns are closed courses drawn into the snapshot.
  const io::Frame fr = sim->frame();
  const io::Phase* yarn = fr.find("yarn");
  ASSERT_NE(yarn, nullptr);
  const auto ids = yarn->find("yarn")->as<std::uint32_t>();
  ASSERT_FALSE(ids.empty());
  EXPECT_GT(*std::max_element(ids.begin(), ids.end()), 10u);
}
