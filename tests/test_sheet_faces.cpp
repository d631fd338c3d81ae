// The knit's sheet as triangles (P8 stage 5): a flat patch's faces cover its front and back
// exactly (their areas sum to the patch's on each layer, none overlaps: each face's normal the
// layer's), an interior point belongs to six faces, a tube closes its seam, and every point's
// face list names exactly the faces holding it.
#include "domain/SheetFaces.hpp"
#include "support/KnitChecks.hpp"

#include <gtest/gtest.h>

#include <cmath>

using namespace kf;

namespace {

double area(const std::vector<Vec3d>& x, const std::array<std::uint32_t, 3>& f) {
  return 0.5 * norm(cross(x[f[1]] - x[f[0]], x[f[2]] - x[f[0]]));
}

void check_lists(const SheetFaces& s, std::size_t points) {
  ASSERT_EQ(s.offsets.size(), points + 1);
  for (std::size_t p = 0; p < points; ++p)
    for (std::uint32_t k = s.offsets[p]; k < s.offsets[p + 1]; ++k) {
      const auto& f = s.faces[s.ids[k]];
      EXPECT_TRUE(f[0] == p || f[1] == p || f[2] == p) << "point " << p;
    }
  EXPECT_EQ(s.ids.size(), 3 * s.faces.size());
}

} // namespace

TEST(SheetFaces, APatchsFacesCoverItsFrontAndBack) {
  Scene scene = test::knit_only_scene("sheet");
  KnitPiece p;
  p.width = 0.2;
  p.height = 0.1;
  p.wales = 8;
  p.courses = 4;
  scene.knit.pieces.push_back(p);
  const KnitMesh mesh = build_knit(scene);
  const SheetFaces s = build_sheet_faces(mesh);
  const auto& L = mesh.pieces[0];
  ASSERT_EQ(s.faces.size(), std::size_t(2 * 2 * (L.nu - 1) * (L.nv - 1)));
  double front = 0, back = 0;
  for (const auto& f : s.faces) {
    const double a = area(mesh.x, f);
    (mesh.layer[f[0]] == 0 ? front : back) += a;
    EXPECT_EQ(mesh.layer[f[0]], mesh.layer[f[1]]);
    EXPECT_EQ(mesh.layer[f[0]], mesh.layer[f[2]]);
    // Flat and not folded back: every face's normal along the patch's (z).
    const Vec3d n = cross(mesh.x[f[1]] - mesh.x[f[0]], mesh.x[f[2]] - mesh.x[f[0]]);
    EXPECT_GT(n.z, 0.0);
  }
  // The grid spans the piece's width and height (to rounding of its spacing).
  const double span_u = norm(mesh.x[L.index(0, L.nu - 1, 0)] - mesh.x[L.index(0, 0, 0)]);
  const double span_v = norm(mesh.x[L.index(0, 0, L.nv - 1)] - mesh.x[L.index(0, 0, 0)]);
  EXPECT_NEAR(front, span_u * span_v, 1e-12);
  EXPECT_NEAR(back, span_u * span_v, 1e-12);
  // An interior point of the front: six faces (two quads' splits meet it along the diagonal).
  const std::uint32_t mid = L.index(0, L.nu / 2, L.nv / 2);
  EXPECT_EQ(s.offsets[mid + 1] - s.offsets[mid], 6u);
  // The middle layer has no faces.
  const std::uint32_t middle = L.index(1, 1, 1);
  EXPECT_EQ(s.offsets[middle + 1] - s.offsets[middle], 0u);
  check_lists(s, mesh.x.size());
}

TEST(SheetFaces, ATubeClosesItsSeam) {
  Scene scene = test::knit_only_scene("tube");
  KnitPiece p;
  p.shape = KnitShape::Tube;
  p.circumference = 0.2;
  p.length = 0.1;
  p.wales = 10;
  p.courses = 4;
  scene.knit.pieces.push_back(p);
  const KnitMesh mesh = build_knit(scene);
  const SheetFaces s = build_sheet_faces(mesh);
  const auto& L = mesh.pieces[0];
  ASSERT_TRUE(L.periodic_u);
  EXPECT_EQ(s.faces.size(), std::size_t(2 * 2 * L.nu * (L.nv - 1)));
  // Every point of an inner course of the front belongs to six faces: no seam left open.
  for (int i = 0; i < L.nu; ++i) {
    const std::uint32_t q = L.index(0, i, 1);
    EXPECT_EQ(s.offsets[q + 1] - s.offsets[q], 6u) << "wale " << i;
  }
  check_lists(s, mesh.x.size());
}
