// Signed distance of mesh obstacles against independent references: an OBJ box against the
// analytic box, an icosphere against the sphere it is inscribed in, a torus of quads (saddles,
// a hole) against a brute-force distance signed by the winding number. Also the mesh checks
// (closed, manifold, oriented) and the grid of a 10k-triangle mesh (bench_mesh_sdf times it).
//
// Tolerances, all derived rather than tuned (h: grid cell; I: the trilinear interpolant):
// - The samples are exact distances, and every signed distance is 1-Lipschitz, so at any point
//   |I(x) - f(x)| <= B(x) = sum_i w_i |c_i - x| over the cell's corners c_i (w_i the trilinear
//   weights; B <= sqrt(3)/2 h).
// - Where f is linear over the whole cell (a box away from its edges), I(x) = f(x) exactly.
// - A convex solid has a convex signed distance, so I(x) >= f(x) (Jensen).
// - The icosphere P lies between the spheres of radius r_in (its faces' distance from the centre)
//   and r, so |x| - r <= f(x) <= |x| - r_in, and for g = |x| - r, |I(g) - g| <= 3 h^2 / (8 rho)
//   (g's Hessian is at most 1/rho, rho the smallest |x| over the cell); hence
//   g <= I(f) <= g + (r - r_in) + 3 h^2 / (8 rho).
#include "core/Error.hpp"
#include "domain/MeshObstacle.hpp"
#include "domain/MeshSdf.hpp"
#include "domain/RigidShapes.hpp"
#include "io/ObjReader.hpp"
#include "support/MeshReference.hpp"

#include <gtest/gtest.h>

#include <cstdio>
#include <memory>
#include <random>

using namespace kf;

namespace {

std::shared_ptr<MeshObstacle> mesh_obstacle(const std::string& obj_text,
                                            const SdfResolution& res = {}) {
  auto m = std::make_shared<MeshObstacle>();
  m->solid = make_mesh_solid(io::parse_obj(obj_text, "t.obj"), 1.0, {0, 0, 0});
  m->sdf = sample_sdf(m->solid, res);
  return m;
}

/// The mesh as the run sees it: a RigidShape of kind Mesh from the shapes table.
template <typename T>
struct MeshShape {
  Scene scene;
  std::unique_ptr<RigidShapes<T>> shapes;
  explicit MeshShape(std::shared_ptr<const MeshObstacle> m) {
    scene.domain.walls.fill(false);
    Obstacle o;
    o.shape = ObstacleShape::Mesh;
    o.mesh = std::move(m);
    scene.obstacles = {o};
    shapes = std::make_unique<RigidShapes<T>>(scene);
  }
  const RigidShape<T>& shape() const { return shapes->table().at(0); }
};

/// The trilinear interpolation bound B(x) of a 1-Lipschitz function, and the cell's corners.
struct Cell {
  std::array<Vec3d, 8> corner;
  double bound = 0;
};

Cell cell_of(const SdfGrid& g, const Vec3d& x) {
  Cell c;
  double t[3];
  std::uint32_t i[3];
  for (int k = 0; k < 3; ++k) {
    const double f = ((&x.x)[k] - (&g.origin.x)[k]) / g.cell;
    i[k] = std::min<std::uint32_t>(std::uint32_t(std::max(0.0, f)), g.dims[k] - 2);
    t[k] = f - i[k];
  }
  for (int n = 0; n < 8; ++n) {
    const int a = n & 1, b = (n >> 1) & 1, e = (n >> 2) & 1;
    c.corner[n] = g.node(i[0] + a, i[1] + b, i[2] + e);
    const double w = (a ? t[0] : 1 - t[0]) * (b ? t[1] : 1 - t[1]) * (e ? t[2] : 1 - t[2]);
    c.bound += w * norm(c.corner[n] - x);
  }
  return c;
}

Vec3d random_in(std::mt19937& rng, const Vec3d& lo, const Vec3d& hi) {
  std::uniform_real_distribution<double> u(0, 1);
  return {lo.x + (hi.x - lo.x) * u(rng), lo.y + (hi.y - lo.y) * u(rng),
          lo.z + (hi.z - lo.z) * u(rng)};
}

/// Which linear piece of the box's signed distance holds p: face k (0..2) on side s (+1/-1) as
/// 2k + (s > 0), or -1 where the distance is not linear (outside beyond an edge or corner).
/// Each piece is convex, so a cell whose 8 corners share a piece lies in it.
int box_piece(const Vec3d& p, const Vec3d& lo, const Vec3d& hi) {
  const Vec3d c = (lo + hi) * 0.5, half = (hi - lo) * 0.5;
  double q[3], s[3];
  for (int k = 0; k < 3; ++k) {
    const double d = (&p.x)[k] - (&c.x)[k];
    q[k] = std::fabs(d) - (&half.x)[k];
    s[k] = d < 0 ? -1 : 1;
  }
  for (int k = 0; k < 3; ++k) {
    bool in = true; // q_j <= min(q_k, 0) for the other axes
    for (int j = 0; j < 3; ++j)
      if (j != k && q[j] > std::min(q[k], 0.0))
        in = false;
    if (in)
      return 2 * k + (s[k] > 0);
  }
  return -1;
}

} // namespace

TEST(MeshSdf, CubeMatchesTheAnalyticBox) {
  const Vec3d lo{0.1, -0.2, 0.3}, hi{0.5, 0.4, 0.6};
  const auto m = mesh_obstacle(test::cube_obj(lo, hi));
  ASSERT_EQ(m->solid.triangles.size(), 12u);
  EXPECT_NEAR(m->solid.volume, 0.4 * 0.6 * 0.3, 1e-12);
  const SdfGrid& g = m->sdf;
  const MeshShape<double> mesh(m);
  RigidShape<double> box;
  box.kind = ShapeKind::Box;
  box.a = lo;
  box.b = hi;

  std::mt19937 rng(11);
  int linear = 0, sign_checked = 0;
  double worst_linear = 0, worst_rel = 0, worst_normal_linear = 0;
  for (int n = 0; n < 40000; ++n) {
    const Vec3d x = random_in(rng, g.origin, g.far_corner());
    Vec3d nm, nb;
    const double dm = mesh.shape().distance(x, nm), db = box.distance(x, nb);
    const Cell c = cell_of(g, x);
    // Convex: never below the exact distance; 1-Lipschitz: at most B(x) above it.
    ASSERT_GE(dm - db, -1e-12) << "at " << x.x << " " << x.y << " " << x.z;
    ASSERT_LE(dm - db, c.bound + 1e-12) << "at " << x.x << " " << x.y << " " << x.z;
    worst_rel = std::max(worst_rel, (dm - db) / g.cell);
    const int piece = box_piece(c.corner[0], lo, hi);
    bool same = piece >= 0;
    for (int k = 1; k < 8 && same; ++k)
      same = box_piece(c.corner[k], lo, hi) == piece;
    if (same) { // the box's distance is linear on the cell: reproduced exactly, normal too
      ++linear;
      worst_linear = std::max(worst_linear, std::fabs(dm - db));
      worst_normal_linear = std::max(worst_normal_linear, norm(nm - nb));
    }
    if (std::fabs(db) > c.bound) {
      ++sign_checked;
      ASSERT_EQ(dm < 0, db < 0) << "wrong sign at " << x.x << " " << x.y << " " << x.z;
    }
    // The normal points to the free side: within 90 degrees of the box's near the surface
    // (deep inside, across the box's medial planes, the interpolated gradient may vanish).
    if (std::fabs(db) < 3 * g.cell) {
      ASSERT_GT(dot(nm, nb), 0.0) << "at " << x.x << " " << x.y << " " << x.z;
    }
  }
  std::printf("cube: grid %u x %u x %u, cell %.4g; %d of 40000 points in cells where the box is "
              "linear: worst |error| %.2e (normal %.2e); elsewhere worst error %.3f cells; "
              "sign checked at %d points\n",
              g.dims[0], g.dims[1], g.dims[2], g.cell, linear, worst_linear, worst_normal_linear,
              worst_rel, sign_checked);
  EXPECT_GT(linear, 20000);
  EXPECT_LT(worst_linear, 1e-12);
  EXPECT_LT(worst_normal_linear, 1e-9);
  EXPECT_LE(worst_rel, std::sqrt(3.0) / 2);
}

TEST(MeshSdf, IcosphereMatchesTheSphereWithinChordAndInterpolationError) {
  const Vec3d c{0.1, 0.2, -0.1};
  const double r = 0.3;
  const auto m = mesh_obstacle(test::icosphere_obj(3, c, r));
  ASSERT_EQ(m->solid.triangles.size(), 1280u);
  double r_in = r; // distance of the nearest face plane from the centre
  for (const auto& t : m->solid.triangles) {
    const Vec3d a = m->solid.vertices[t[0]], b = m->solid.vertices[t[1]],
                e = m->solid.vertices[t[2]];
    const Vec3d n = cross(b - a, e - a);
    r_in = std::min(r_in, dot(a - c, n) / norm(n));
  }
  const double chord = r - r_in;
  const SdfGrid& g = m->sdf;
  const MeshShape<double> mesh(m);
  std::mt19937 rng(5);
  double worst_low = 0, worst_high = 0, min_cos = 1;
  int checked = 0, inside = 0;
  for (int n = 0; n < 40000; ++n) {
    const Vec3d x = random_in(rng, g.origin, g.far_corner());
    Vec3d nm;
    const double dm = mesh.shape().distance(x, nm);
    const double rho = norm(x - c), sphere = rho - r;
    // Lower bound everywhere (convex mesh inside the sphere); the sign follows outside it.
    ASSERT_GE(dm - sphere, -1e-12) << "at " << x.x << " " << x.y << " " << x.z;
    worst_low = std::min(worst_low, dm - sphere);
    const double rho_min = rho - std::sqrt(3.0) * g.cell;
    if (rho_min < 0.5 * r) { // near the centre: deep inside
      ASSERT_LT(dm, 0.0);
      continue;
    }
    const double eps = 3 * g.cell * g.cell / (8 * rho_min);
    ASSERT_LE(dm - sphere, chord + eps + 1e-12) << "at " << x.x << " " << x.y << " " << x.z;
    worst_high = std::max(worst_high, dm - sphere);
    if (sphere < -(chord + eps)) {
      ASSERT_LT(dm, 0.0);
      ++inside;
    }
    ++checked;
    const double cosang = dot(nm, (x - c) * (1 / rho));
    min_cos = std::min(min_cos, cosang);
    ASSERT_GT(cosang, 0.9) << "normal off the radial direction at " << x.x << " " << x.y << " "
                           << x.z;
  }
  std::printf("icosphere (1280 triangles): chord error r - r_in = %.3e (%.3f cells, cell %.4g); "
              "mesh - sphere distance in [%.2e, %.2e] over %d points (%d clearly inside); "
              "normals within %.2f degrees of radial\n",
              chord, chord / g.cell, g.cell, worst_low, worst_high, checked, inside,
              std::acos(min_cos) * 180 / std::numbers::pi);
  EXPECT_GT(inside, 1000);
}

TEST(MeshSdf, NormalsPointToTheFreeSide) {
  // Stepping along the normal by a fraction of a cell increases the distance, on a non-convex
  // mesh (saddles, a hole) and a convex one.
  for (const std::string& text :
       {test::torus_obj({0, 0, 0}, 0.3, 0.1, 32, 16), test::icosphere_obj(2, {0, 0, 0}, 0.25)}) {
    const auto m = mesh_obstacle(text);
    const MeshShape<double> mesh(m);
    std::mt19937 rng(3);
    int near_surface = 0;
    for (int n = 0; n < 20000; ++n) {
      const Vec3d x = random_in(rng, m->sdf.origin, m->sdf.far_corner());
      Vec3d nrm, ignored;
      const double d = mesh.shape().distance(x, nrm);
      if (std::fabs(d) > 3 * m->sdf.cell)
        continue; // medial-axis points deep inside may have a vanishing gradient
      ++near_surface;
      const double step = 0.25 * m->sdf.cell;
      ASSERT_GT(mesh.shape().distance(x + nrm * step, ignored), d)
          << "at " << x.x << " " << x.y << " " << x.z;
      ASSERT_NEAR(norm(nrm), 1.0, 1e-12);
    }
    EXPECT_GT(near_surface, 1000);
  }
}

TEST(MeshSdf, TorusOfQuadsMatchesABruteForceWindingNumberReference) {
  const auto m = mesh_obstacle(test::torus_obj({0.05, -0.02, 0.1}, 0.3, 0.1, 40, 20));
  const test::RefMesh ref{m->solid.vertices, m->solid.triangles};
  ASSERT_EQ(ref.tri.size(), 2u * 40 * 20);
  const SdfGrid& g = m->sdf;
  // The samples are the exact distance: every node equals the reference.
  std::mt19937 rng(7);
  double worst_node = 0;
  int nodes_inside = 0;
  for (int n = 0; n < 3000; ++n) {
    const auto i = std::uint32_t(rng() % g.dims[0]), j = std::uint32_t(rng() % g.dims[1]),
               k = std::uint32_t(rng() % g.dims[2]);
    const double want = test::ref_signed_distance(ref, g.node(i, j, k));
    const double got = g.values[g.index(i, j, k)];
    ASSERT_NEAR(got, want, 1e-12) << "node " << i << " " << j << " " << k;
    worst_node = std::max(worst_node, std::fabs(got - want));
    nodes_inside += want < 0;
  }
  // Between the nodes, within the Lipschitz bound of trilinear interpolation; the sign right
  // wherever the distance exceeds that bound.
  const MeshShape<double> mesh(m);
  double worst_rel = 0;
  int signed_points = 0;
  for (int n = 0; n < 3000; ++n) {
    const Vec3d x = random_in(rng, g.origin, g.far_corner());
    Vec3d nrm;
    const double got = mesh.shape().distance(x, nrm);
    const double want = test::ref_signed_distance(ref, x);
    const Cell c = cell_of(g, x);
    ASSERT_LE(std::fabs(got - want), c.bound + 1e-12) << "at " << x.x << " " << x.y << " " << x.z;
    worst_rel = std::max(worst_rel, std::fabs(got - want) / g.cell);
    if (std::fabs(want) > c.bound) {
      ASSERT_EQ(got < 0, want < 0);
      ++signed_points;
    }
  }
  std::printf("torus (1600 triangles from 800 quads): nodes exact to %.1e (%d of 3000 inside); "
              "between nodes worst error %.3f cells; sign checked at %d points\n",
              worst_node, nodes_inside, worst_rel, signed_points);
  EXPECT_GT(nodes_inside, 100);
}

TEST(MeshSdf, ExactDistanceIsSignedRightAtSharpEdgesAndTips) {
  // A tall thin tetrahedron: dihedral angles of a few degrees along its long edges and a needle
  // tip, where the normal of one face alone gives the wrong sign on the other face's side (the
  // two faces' normals point almost opposite ways); the pseudonormals of edges and vertices do
  // not. Checked exactly (no grid) against the winding-number reference around the spike.
  const std::string text = "v 0 0 0\nv 0.1 0 0\nv 0.05 0.08 0\nv 0.05 0.03 1\n"
                           "f 1 3 2\nf 1 2 4\nf 2 3 4\nf 3 1 4\n";
  const MeshSolid solid = make_mesh_solid(io::parse_obj(text, "spike.obj"), 1.0, {0, 0, 0});
  const MeshDistance distance(solid);
  const test::RefMesh ref{solid.vertices, solid.triangles};
  std::mt19937 rng(9);
  int inside = 0, near_tip = 0;
  for (int n = 0; n < 20000; ++n) {
    // Half the points around the tip, half anywhere around the spike.
    const Vec3d x = n % 2 ? random_in(rng, {0.0, -0.02, 0.9}, {0.1, 0.08, 1.05})
                          : random_in(rng, {-0.05, -0.05, -0.05}, {0.15, 0.13, 1.05});
    const double want = test::ref_signed_distance(ref, x);
    ASSERT_NEAR(distance(x), want, 1e-12) << "at " << x.x << " " << x.y << " " << x.z;
    inside += want < 0;
    near_tip += norm(x - Vec3d{0.05, 0.03, 1}) < 0.02;
  }
  EXPECT_GT(inside, 200);
  EXPECT_GT(near_tip, 100);
}

TEST(MeshSdf, BeyondTheGridTheDistanceStaysPositiveAndGrows) {
  const Vec3d c{0, 0, 0};
  const double r = 0.2;
  const auto m = mesh_obstacle(test::icosphere_obj(2, c, r));
  const MeshShape<double> mesh(m);
  const SdfGrid& g = m->sdf;
  double last = 0;
  for (double s = 0; s < 2.0; s += 0.05) { // from the centre outward, past the grid's corner
    const Vec3d x = c + Vec3d{1, 0.7, 0.4} * s;
    Vec3d nrm;
    const double d = mesh.shape().distance(x, nrm);
    const double sphere = norm(x - c) - r;
    EXPECT_GE(d, sphere - 1e-12) << s; // never closer than the true distance (convex)
    if (s > 0.3) {
      EXPECT_GT(d, last) << s;
    }
    last = d;
    if (sphere > 0) {
      EXPECT_GT(dot(nrm, x - c), 0.0) << s;
    }
  }
  EXPECT_GT(norm(Vec3d{1, 0.7, 0.4} * 2.0), norm(g.far_corner() - c)) << "the walk left the grid";
}

TEST(MeshSdf, FloatShapeAgreesWithDouble) {
  const auto m = mesh_obstacle(test::torus_obj({0.5, 0.5, 0.5}, 0.3, 0.1, 24, 12));
  const MeshShape<double> md(m);
  const MeshShape<float> mf(m);
  std::mt19937 rng(2);
  double worst = 0;
  for (int n = 0; n < 5000; ++n) {
    const Vec3d x = random_in(rng, m->sdf.origin - Vec3d{0.1, 0.1, 0.1},
                              m->sdf.far_corner() + Vec3d{0.1, 0.1, 0.1});
    Vec3d nd;
    Vec3<float> nf;
    const double d = md.shape().distance(x, nd);
    const double f = mf.shape().distance(vec_cast<float>(x), nf);
    worst = std::max(worst, std::fabs(d - f));
  }
  EXPECT_LT(worst, 1e-5) << "float and double differ by more than rounding";
}

TEST(MeshSdf, MovingMeshFollowsItsOffset) {
  const auto m = mesh_obstacle(test::icosphere_obj(2, {0, 0, 0}, 0.2));
  MeshShape<double> mesh(m);
  RigidShape<double> s = mesh.shape();
  Vec3d n;
  const double d0 = s.distance({0.3, 0, 0}, n);
  s.offset = {0.1, 0, 0};
  EXPECT_NEAR(s.distance({0.4, 0, 0}, n), d0, 1e-12);
}

// The mesh bench_mesh_sdf times (no wall-clock assertion here: a loaded machine would fail it).
TEST(MeshSdf, TenThousandTrianglesSampleOnTheDefaultGrid) {
  // A torus of 72 x 70 quads: 10,080 triangles, at the default 64^3 samples.
  const std::string text = test::torus_obj({0, 0, 0}, 0.3, 0.12, 72, 70);
  const MeshSolid solid = make_mesh_solid(io::parse_obj(text, "t.obj"), 1.0, {0, 0, 0});
  ASSERT_EQ(solid.triangles.size(), 10080u);
  const SdfGrid g = sample_sdf(solid);
  std::printf("10,080 triangles sampled on %u x %u x %u = %zu nodes\n", g.dims[0], g.dims[1],
              g.dims[2], g.values.size());
  EXPECT_LE(g.values.size(), SdfResolution{}.max_samples);
  EXPECT_GT(g.values.size(), SdfResolution{}.max_samples / 2);
}

TEST(MeshSdf, GridCoversTheMeshWithAMarginAndRespectsTheCap) {
  for (const Vec3d& ext : {Vec3d{1, 1, 1}, Vec3d{2, 0.1, 0.1}, Vec3d{1, 1, 0.01}}) {
    const Vec3d lo{-0.3, 0.2, 1.0};
    const SdfGrid g = sdf_grid_geometry(lo, lo + ext);
    const double n = double(g.dims[0]) * g.dims[1] * g.dims[2];
    EXPECT_LE(n, double(SdfResolution{}.max_samples));
    EXPECT_GT(n, 0.8 * SdfResolution{}.max_samples) << "the cap should be nearly used";
    const Vec3d far = g.far_corner();
    for (int k = 0; k < 3; ++k) {
      EXPECT_LE((&g.origin.x)[k], (&lo.x)[k] - 3 * g.cell + 1e-12);
      EXPECT_GE((&far.x)[k], (&lo.x)[k] + (&ext.x)[k] + 3 * g.cell - 1e-12);
    }
  }
}

// A mesh that does not bound a solid: the OBJ text and what the message must say.
struct BadMesh {
  const char* name;
  std::string text;
  const char* says;
};

std::string cube_without_last_face() {
  std::string s = test::cube_obj({0, 0, 0}, {1, 1, 1});
  s.erase(s.rfind("f "));
  s.erase(s.rfind("f "));
  return s;
}

std::string cube_with_a_fin() {
  // A 13th triangle on the edge (1, 2) of the first face: that edge has three faces.
  return test::cube_obj({0, 0, 0}, {1, 1, 1}) + "v 0.5 -1 -1\nf 1 2 9\n";
}

std::string cube_with_a_flipped_triangle() {
  std::string s = test::cube_obj({0, 0, 0}, {1, 1, 1});
  const std::size_t at = s.find("f 1 3 4");
  s.replace(at, 7, "f 1 4 3");
  return s;
}

TEST(MeshSolidCheck, RejectsMeshesThatDoNotBoundASolid) {
  const BadMesh bad[] = {
      {"open", cube_without_last_face(),
       "mesh 't.obj' is not closed: edge (2, 4) belongs to 1 face (t.obj:"},
      {"fin", cube_with_a_fin(),
       "mesh 't.obj' is not a manifold: edge (1, 2) belongs to 3 faces (t.obj:"},
      {"flipped", cube_with_a_flipped_triangle(),
       "mesh 't.obj' is not consistently oriented: edge"},
      {"repeated", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 2 3\n",
       "mesh 't.obj': the face on t.obj:4 uses vertex 2 twice"},
      {"flat", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 3 2\n", "mesh 't.obj' encloses no volume"},
      {"empty", "v 0 0 0\n", "mesh 't.obj' has no faces"},
  };
  for (const BadMesh& b : bad) {
    try {
      make_mesh_solid(io::parse_obj(b.text, "t.obj"), 1.0, {0, 0, 0});
      ADD_FAILURE() << b.name << ": accepted";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(b.says), std::string::npos)
          << b.name << ": " << e.what();
    }
  }
}

TEST(MeshSolidCheck, TurnsAnInwardMeshOutward) {
  // The cube with every face reversed: consistently oriented, wound inward.
  std::string s = test::cube_obj({0, 0, 0}, {1, 1, 1});
  const io::ObjMesh in = io::parse_obj(s, "t.obj");
  std::string reversed;
  for (const Vec3d& x : in.vertices)
    reversed +=
        "v " + std::to_string(x.x) + " " + std::to_string(x.y) + " " + std::to_string(x.z) + "\n";
  for (std::size_t f = 0; f < in.faces(); ++f) {
    const auto v = in.face(f);
    reversed += "f " + std::to_string(v[2] + 1) + " " + std::to_string(v[1] + 1) + " " +
                std::to_string(v[0] + 1) + "\n";
  }
  const auto m = mesh_obstacle(reversed);
  EXPECT_NEAR(m->solid.volume, 1.0, 1e-12);
  const MeshShape<double> mesh(m);
  Vec3d n;
  EXPECT_NEAR(mesh.shape().distance({0.5, 0.5, 0.4}, n), -0.4, 1e-12);
  EXPECT_NEAR(mesh.shape().distance({0.5, 0.5, 1.2}, n), 0.2, 1e-12);
}

TEST(MeshSolidCheck, ScaleAndTranslatePlaceTheVertices) {
  const MeshSolid m =
      make_mesh_solid(io::parse_obj(test::cube_obj({0, 0, 0}, {1, 1, 1}), "t.obj"), 0.5, {1, 2, 3});
  EXPECT_DOUBLE_EQ(m.lo.x, 1);
  EXPECT_DOUBLE_EQ(m.hi.z, 3.5);
  EXPECT_NEAR(m.volume, 0.125, 1e-15);
}
