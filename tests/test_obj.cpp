// The OBJ reader: v and f records in every index form, polygons kept, relative indices, skipped
// records; fan triangulation; one-line "FILE:LINE: ..." errors for malformed files.
#include "core/Error.hpp"
#include "io/ObjReader.hpp"
#include "support/TestPaths.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <numbers>
#include <string>
#include <vector>

using namespace kf;
using namespace kf::io;

namespace {

std::vector<std::uint32_t> face_of(const ObjMesh& m, std::size_t f) {
  const auto v = m.face(f);
  return {v.begin(), v.end()};
}

/// The message of the kf::Error parsing throws ("" and a test failure when none is thrown).
std::string parse_error(const std::string& text) {
  try {
    parse_obj(text, "t.obj");
  } catch (const Error& e) {
    return e.what();
  }
  ADD_FAILURE() << "parsed without an error:\n" << text;
  return "";
}

} // namespace

TEST(Obj, ReadsVerticesAndPolygonFacesInEveryIndexForm) {
  const std::string text = "# a comment\n"
                           "mtllib x.mtl\n"
                           "o thing\n"
                           "v 0 0 0\n"
                           "v 1.5 0 0   # trailing comment\n"
                           "v +1 1 -2e-1\n"
                           "v 0 1 0 1.0\n"         // with w
                           "v 0 0 1 0.5 0.5 0.5\n" // with a colour
                           "vt 0 0\nvn 0 0 1\ng grp\ns off\nusemtl m\n"
                           "\n"
                           "f 1 2 3\n"
                           "f 1/1 2/1 3/1 4/1\n"
                           "f 1//1 3//1 \\\n" // continued on the next line
                           "  5//1\n"
                           "f 2/1/1 3/1/1 4/1/1 5/1/1 1/1/1\n"
                           "f -5 -4 -1\n" // relative: 1 2 5
                           "l 1 2\n";
  const ObjMesh m = parse_obj(text, "t.obj");
  ASSERT_EQ(m.vertices.size(), 5u);
  EXPECT_DOUBLE_EQ(m.vertices[1].x, 1.5);
  EXPECT_DOUBLE_EQ(m.vertices[2].x, 1.0);
  EXPECT_DOUBLE_EQ(m.vertices[2].z, -0.2);
  EXPECT_DOUBLE_EQ(m.vertices[4].z, 1.0);
  ASSERT_EQ(m.faces(), 5u);
  EXPECT_EQ(face_of(m, 0), (std::vector<std::uint32_t>{0, 1, 2}));
  EXPECT_EQ(face_of(m, 1), (std::vector<std::uint32_t>{0, 1, 2, 3}));
  EXPECT_EQ(face_of(m, 2), (std::vector<std::uint32_t>{0, 2, 4}));
  EXPECT_EQ(face_of(m, 3), (std::vector<std::uint32_t>{1, 2, 3, 4, 0}));
  EXPECT_EQ(face_of(m, 4), (std::vector<std::uint32_t>{0, 1, 4}));
  EXPECT_EQ(m.face_line, (std::vector<int>{15, 16, 17, 19, 20}));
}

TEST(Obj, RelativeIndicesCountFromTheVerticesReadSoFar) {
  const ObjMesh m = parse_obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\n"
                              "v 0 0 1\nf -4 -1 -2\n",
                              "t.obj");
  EXPECT_EQ(face_of(m, 0), (std::vector<std::uint32_t>{0, 1, 2}));
  EXPECT_EQ(face_of(m, 1), (std::vector<std::uint32_t>{0, 3, 2}));
}

TEST(Obj, ForwardReferencesAreAllowed) {
  const ObjMesh m = parse_obj("f 1 2 3\nv 0 0 0\nv 1 0 0\nv 0 1 0\n", "t.obj");
  EXPECT_EQ(face_of(m, 0), (std::vector<std::uint32_t>{0, 1, 2}));
}

TEST(Obj, FanTriangulationKeepsWindingAndArea) {
  // A regular hexagon in the xy plane, counter-clockwise: 4 triangles, all with +z normals,
  // areas summing to the hexagon's.
  std::string text;
  for (int k = 0; k < 6; ++k)
    text += "v " + std::to_string(std::cos(k * std::numbers::pi / 3)) + " " +
            std::to_string(std::sin(k * std::numbers::pi / 3)) + " 0\n";
  text += "f 1 2 3 4 5 6\nf 1 2 3\n";
  const ObjMesh m = parse_obj(text, "hex.obj");
  const auto tris = fan_triangles(m);
  ASSERT_EQ(tris.size(), 5u);
  double area = 0;
  for (std::size_t t = 0; t < 4; ++t) {
    EXPECT_EQ(tris[t].face, 0u);
    EXPECT_EQ(tris[t].v[0], 0u);
    EXPECT_EQ(tris[t].v[1], t + 1);
    EXPECT_EQ(tris[t].v[2], t + 2);
    const Vec3d n = cross(m.vertices[tris[t].v[1]] - m.vertices[tris[t].v[0]],
                          m.vertices[tris[t].v[2]] - m.vertices[tris[t].v[0]]);
    EXPECT_GT(n.z, 0);
    area += 0.5 * n.z;
  }
  EXPECT_NEAR(area, 1.5 * std::sqrt(3.0), 1e-5);
  EXPECT_EQ(tris[4].face, 1u);
}

struct BadObj {
  const char* text;
  const char* says; // the message must start with "t.obj:LINE: " and contain this
  int line;
};

// clang-format off
const BadObj kBadObj[] = {
  {"v 0 0 0\nv 1 x 0\n", "vertex: expected a number, got 'x'", 2},
  {"v 0 0\n", "vertex: expected 3 coordinates", 1},
  {"v 0 0 nan\n", "vertex: expected a finite number, got 'nan'", 1},
  {"v 0 0 1e999\n", "vertex: expected a number, got '1e999'", 1},
  {"v 0 0 0\nv 1 0 0\nf 1 2\n", "face: expected at least 3 vertices, got 2", 3},
  {"v 0 0 0\nv 1 0 0\nv 0 1 0\n\nf 1 2 4\n", "face: vertex index 4 is out of range (the file has 3 vertices)", 5},
  {"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", "face: vertex index 0 in '0'", 4},
  {"v 0 0 0\nv 1 0 0\nf -1 -2 -3\nv 0 1 0\n", "relative vertex index -3 is out of range (2 vertices read so far)", 3},
  {"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/a 2 3\n", "face: expected an index (v, v/vt, v//vn or v/vt/vn), got '1/a'", 4},
  {"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1.5 2 3\n", "got '1.5'", 4},
  {"v 0 0 0\nv 1 0 0\nv 0 1 0\nf /1 2 3\n", "face: expected a vertex index, got '/1'", 4},
  {"# ok\nvx 1 2 3\n", "unknown OBJ record 'vx'", 2},
};
// clang-format on

class BadObjTest : public ::testing::TestWithParam<BadObj> {};

TEST_P(BadObjTest, FailsNamingFileAndLine) {
  const BadObj& b = GetParam();
  const std::string msg = parse_error(b.text);
  EXPECT_EQ(msg.rfind("t.obj:" + std::to_string(b.line) + ": ", 0), 0u) << msg;
  EXPECT_NE(msg.find(b.says), std::string::npos) << msg;
  EXPECT_EQ(msg.find('\n'), std::string::npos) << "not one line: " << msg;
}

INSTANTIATE_TEST_SUITE_P(Texts, BadObjTest, ::testing::ValuesIn(kBadObj));

/// What read_obj says of a file it cannot read ("" where it reads one).
std::string open_error(const std::string& path) {
  try {
    read_obj(path);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(Obj, MissingFileNamesPath) {
  const std::string path = (test::data_dir() / "meshes" / "no_such.obj").string();
  const std::string msg = open_error(path);
  EXPECT_EQ(msg.rfind(path + ": cannot open OBJ file (No such file or directory)", 0), 0u) << msg;
}

TEST(Obj, DirectoryIsRefusedWithItsReason) {
  // An ifstream opens a directory on Linux and reads nothing: the reader must say why instead.
  const std::string path = (test::data_dir() / "meshes").string();
  const std::string msg = open_error(path);
  EXPECT_EQ(msg.rfind(path + ": cannot open OBJ file (Is a directory)", 0), 0u) << msg;
}

TEST(Obj, ReadsAFile) {
  const auto dir = test::scratch_dir("obj_file");
  const std::string path = (dir / "tri.obj").string();
  std::ofstream(path) << "v 0 0 0\r\nv 1 0 0\r\nv 0 1 0\r\nf 1 2 3\r\n"; // CRLF line ends
  const ObjMesh m = read_obj(path);
  EXPECT_EQ(m.source, path);
  EXPECT_EQ(m.vertices.size(), 3u);
  EXPECT_EQ(face_of(m, 0), (std::vector<std::uint32_t>{0, 1, 2}));
}
