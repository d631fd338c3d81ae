// Scene loading and validation: a full scene and defaults, --set overrides, and one broken scene
// file per rule, each checked for a SceneError naming file, line and key.
#include "core/Error.hpp"
#include "domain/KnitMeshPiece.hpp"
#include "domain/MeshObstacle.hpp"
#include "domain/Samplers.hpp"
#include "domain/Scene.hpp"
#include "domain/SceneCautions.hpp"
#include "support/TestPaths.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <regex>
#include <string>
#include <vector>

namespace kf {
namespace {

std::string scene_file(const std::string& name) {
  return (test::data_dir() / "scenes" / name).string();
}

/// The message of the SceneError that loading throws ("" and a test failure when none is thrown).
std::string load_error(const std::string& path, const std::vector<std::string>& overrides = {}) {
  try {
    load_scene(path, overrides);
  } catch (const SceneError& e) {
    return e.what();
  }
  ADD_FAILURE() << path << " loaded without a SceneError";
  return "";
}

void expect_vec(const Vec3d& v, double x, double y, double z) {
  EXPECT_DOUBLE_EQ(v.x, x);
  EXPECT_DOUBLE_EQ(v.y, y);
  EXPECT_DOUBLE_EQ(v.z, z);
}

TEST(Scene, FullSceneReadsEveryKey) {
  const Scene s = load_scene(scene_file("full.toml"));
  EXPECT_EQ(s.path, scene_file("full.toml"));
  EXPECT_EQ(s.name, "full");
  EXPECT_DOUBLE_EQ(s.end_time, 2.5);
  expect_vec(s.gravity, 0, -9.8, 0);
  EXPECT_EQ(s.modules, (std::vector<Module>{Module::Boundary, Module::Fluid}));
  EXPECT_EQ(s.precision, Precision::Double);

  expect_vec(s.domain.min, -1, -1, 0);
  expect_vec(s.domain.max, 1, 1, 2);
  EXPECT_EQ(s.domain.walls, (std::array<bool, 6>{true, false, false, false, true, false}));

  EXPECT_EQ(s.output.dir, "results/full");
  EXPECT_DOUBLE_EQ(s.output.interval, 0.05);
  EXPECT_FALSE(s.output.enabled);

  EXPECT_EQ(s.solver.kernel, KernelType::WendlandC2);
  EXPECT_DOUBLE_EQ(s.solver.cfl, 0.3);
  EXPECT_DOUBLE_EQ(s.solver.force_factor, 0.2);
  EXPECT_DOUBLE_EQ(s.solver.viscous_factor, 0.15);
  EXPECT_DOUBLE_EQ(s.solver.dt_max, 5e-4);
  EXPECT_DOUBLE_EQ(s.solver.dt_min, 1e-8);
  EXPECT_EQ(s.solver.max_steps, 100);

  EXPECT_DOUBLE_EQ(s.fluid.spacing, 0.02);
  EXPECT_DOUBLE_EQ(s.fluid.support, 2.5);
  EXPECT_DOUBLE_EQ(s.support_radius(), 0.05);
  EXPECT_DOUBLE_EQ(s.fluid.rest_density, 998);
  EXPECT_EQ(s.fluid.eos, EosType::Linear);
  EXPECT_DOUBLE_EQ(s.fluid.speed_of_sound, 30.0); // stiffness 900 = c^2
  EXPECT_DOUBLE_EQ(s.fluid.tait_exponent, 3);
  EXPECT_DOUBLE_EQ(s.fluid.viscosity, 0.002);
  EXPECT_FALSE(s.fluid.clamp_negative_pressure);
  ASSERT_EQ(s.fluid.blocks.size(), 2u);
  expect_vec(s.fluid.blocks[0].velocity, 1, 0, 0);
  expect_vec(s.fluid.blocks[1].min, 0.5, 0.5, 0.5);
  expect_vec(s.fluid.blocks[1].velocity, 0, 0, 0);

  ASSERT_EQ(s.obstacles.size(), 3u);
  EXPECT_EQ(s.obstacles[0].shape, ObstacleShape::Plane);
  EXPECT_EQ(s.obstacles[0].name, "obstacle[0]");
  expect_vec(s.obstacles[0].normal, 0, 0, 1); // normalised
  EXPECT_EQ(s.obstacles[1].name, "crate");
  expect_vec(s.obstacles[1].max, 0.3, 0.3, 0.2);
  expect_vec(s.obstacles[1].velocity, 0, 0.5, 0);
  EXPECT_EQ(s.obstacles[2].shape, ObstacleShape::Sphere);
  EXPECT_EQ(s.obstacles[2].name, "obstacle[2]");
  EXPECT_DOUBLE_EQ(s.obstacles[2].radius, 0.25);
}

TEST(Scene, MinimalSceneTakesDefaults) {
  const Scene s = load_scene(scene_file("minimal.toml"));
  const Scene def;
  EXPECT_EQ(s.name, "scene");
  EXPECT_EQ(s.output.dir, "out/scene");
  EXPECT_DOUBLE_EQ(s.output.interval, def.output.interval);
  EXPECT_TRUE(s.output.enabled);
  EXPECT_EQ(s.precision, Precision::Float);
  expect_vec(s.gravity, 0, 0, -9.81);
  EXPECT_EQ(s.domain.walls, def.domain.walls);
  EXPECT_EQ(s.solver.kernel, KernelType::Spiky);
  EXPECT_DOUBLE_EQ(s.solver.cfl, def.solver.cfl);
  EXPECT_DOUBLE_EQ(s.solver.dt_max, def.solver.dt_max);
  EXPECT_EQ(s.solver.max_steps, 0);
  EXPECT_DOUBLE_EQ(s.fluid.spacing, def.fluid.spacing);
  EXPECT_EQ(s.fluid.eos, EosType::Tait);
  EXPECT_DOUBLE_EQ(s.fluid.speed_of_sound, def.fluid.speed_of_sound);
  EXPECT_TRUE(s.fluid.clamp_negative_pressure);
  EXPECT_TRUE(s.obstacles.empty());
  EXPECT_TRUE(s.has(Module::Fluid) && s.has(Module::Boundary));
}

// A disordered start: every particle within jitter x spacing / 2 of its lattice point along each
// axis, the bound nearly reached (the offsets fill the interval), no drift on average, the same
// on every call; 0 is the lattice; the loader reads the key and refuses past 0.5.
TEST(Scene, FluidBlockJitterIsBoundedUnbiasedAndRepeatable) {
  FluidBlock block;
  block.min = {0, 0, 0};
  block.max = {0.2, 0.2, 0.2};
  const double dp = 0.01;
  const auto lattice = sample_fluid_block(block, dp);
  block.jitter = 0.4;
  const auto a = sample_fluid_block(block, dp), b = sample_fluid_block(block, dp);
  ASSERT_EQ(a.size(), 8000u);
  ASSERT_EQ(lattice.size(), a.size());
  const double bound = 0.4 * dp / 2;
  double largest = 0;
  std::size_t moved = 0;
  Vec3d mean{0, 0, 0};
  for (std::size_t i = 0; i < a.size(); ++i) {
    const Vec3d d = a[i] - lattice[i];
    for (double c : {d.x, d.y, d.z}) {
      ASSERT_LE(std::abs(c), bound) << "particle " << i;
      largest = std::max(largest, std::abs(c));
    }
    moved += norm(d) > 0 ? 1 : 0;
    mean += d * (1.0 / a.size());
    ASSERT_EQ(a[i].x, b[i].x);
    ASSERT_EQ(a[i].y, b[i].y);
    ASSERT_EQ(a[i].z, b[i].z);
  }
  EXPECT_EQ(moved, a.size());
  EXPECT_GT(largest, 0.99 * bound); // 24,000 uniform draws: the largest within 1e-4 of the bound
  // A uniform offset's mean over n draws has sigma = bound / sqrt(3 n): 4 sigma per axis.
  const double four_sigma = 4 * bound / std::sqrt(3.0 * a.size());
  EXPECT_LT(std::abs(mean.x), four_sigma);
  EXPECT_LT(std::abs(mean.y), four_sigma);
  EXPECT_LT(std::abs(mean.z), four_sigma);

  const Scene s = load_scene(scene_file("minimal.toml"), {"fluid.block.0.jitter=0.25"});
  EXPECT_DOUBLE_EQ(s.fluid.blocks[0].jitter, 0.25);
  const std::string msg = load_error(scene_file("minimal.toml"), {"fluid.block.0.jitter=0.6"});
  EXPECT_NE(msg.find("jitter"), std::string::npos) << msg;
  EXPECT_NE(msg.find("expected a number in [0, 0.5], got 0.6"), std::string::npos) << msg;
}

TEST(Scene, OutputDirDefaultsToName) {
  const Scene s =
      parse_scene("[simulation]\nname = \"pour\"\nend_time = 1\nmodules = [\"boundary\"]\n"
                  "[domain]\nmin = [0, 0, 0]\nmax = [1, 1, 1]\nwalls = []\n",
                  "<string>");
  EXPECT_EQ(s.output.dir, "out/pour");
  EXPECT_EQ(s.domain.walls, (std::array<bool, 6>{}));
  EXPECT_EQ(s.path, "<string>");
}

TEST(Scene, StiffnessGivesSpeedOfSound) {
  const Scene s =
      load_scene(scene_file("minimal.toml"), {"fluid.eos=\"linear\"", "fluid.stiffness=400"});
  EXPECT_DOUBLE_EQ(s.fluid.speed_of_sound, 20.0);
}

TEST(Scene, OverridesChangeValues) {
  const Scene s =
      load_scene(scene_file("minimal.toml"),
                 {"fluid.spacing=0.02", "solver.kernel=\"cubic\"", "output.enabled=false",
                  "domain.walls=[\"z-\"]", "simulation.name = pour"});
  EXPECT_DOUBLE_EQ(s.fluid.spacing, 0.02);
  EXPECT_EQ(s.solver.kernel, KernelType::CubicSpline);
  EXPECT_FALSE(s.output.enabled); // [output] is absent from the file
  EXPECT_EQ(s.domain.walls, (std::array<bool, 6>{false, false, false, false, true, false}));
  EXPECT_EQ(s.name, "pour"); // a bare word is a string
  EXPECT_EQ(s.output.dir, "out/pour");
}

TEST(Scene, BareWordOverrideIsAString) {
  const Scene s = load_scene(scene_file("minimal.toml"), {"solver.kernel=wendland"});
  EXPECT_EQ(s.solver.kernel, KernelType::WendlandC2);
}

TEST(Scene, OverrideAddressesArrayOfTablesElement) {
  const Scene s =
      load_scene(scene_file("full.toml"), {"fluid.block.1.velocity=[0, 0, -2]",
                                           "obstacle.2.radius=0.5", "fluid.block.0.max.2=0.5"});
  expect_vec(s.fluid.blocks[0].velocity, 1, 0, 0); // untouched
  expect_vec(s.fluid.blocks[0].max, 0, 0, 0.5);
  expect_vec(s.fluid.blocks[1].velocity, 0, 0, -2);
  expect_vec(s.fluid.blocks[1].min, 0.5, 0.5, 0.5); // merged, not replaced
  EXPECT_DOUBLE_EQ(s.obstacles[2].radius, 0.5);
}

TEST(Scene, TextRecordsOverrides) {
  const Scene s = load_scene(scene_file("minimal.toml"), {"fluid.spacing=0.02"});
  EXPECT_EQ(s.text.find("[simulation]"), s.text.find('['));
  EXPECT_NE(s.text.find("\n# --set fluid.spacing=0.02\n"), std::string::npos);
  EXPECT_EQ(load_scene(scene_file("minimal.toml")).text.find("--set"), std::string::npos);
}

TEST(Scene, ExampleScenesLoad) {
  const Scene dam = load_scene((test::source_dir() / "scenes" / "dambreak.toml").string());
  EXPECT_EQ(dam.fluid.eos, EosType::Tait);
  EXPECT_EQ(dam.output.dir, "out/dambreak");
  expect_vec(dam.fluid.blocks.at(0).max, 0.2, 0.2, 0.4);
  for (const char* name :
       {"hydrostatic.toml", "obstacles.toml", "drape.toml", "mesh_obstacle.toml", "garment.toml"})
    EXPECT_NO_THROW(load_scene((test::source_dir() / "scenes" / name).string())) << name;
}

TEST(Scene, APreviewOfAKnitWithFluidIsCautionedThatItCoarsensTheFluidOnly) {
  const std::string pour = (test::source_dir() / "scenes" / "pour.toml").string();
  EXPECT_TRUE(scene_cautions(load_scene(pour)).empty());
  const auto c = scene_cautions(load_scene(pour, {"solver.quality=\"preview\""}));
  ASSERT_EQ(c.size(), 1u);
  for (const char* says : {"pour.toml", "\"preview\"", "the fluid only", "GPU"})
    EXPECT_NE(c[0].find(says), std::string::npos) << says << " in: " << c[0];
  // A fluid alone, or a knit alone, gets all a preview gives (the drape: nothing to coarsen).
  for (const char* name : {"dambreak.toml", "drape.toml"})
    EXPECT_TRUE(scene_cautions(load_scene((test::source_dir() / "scenes" / name).string(),
                                          {"solver.quality=\"preview\""}))
                    .empty())
        << name;
}

TEST(Scene, CubicSplinePastTwoSpacingsIsCautioned) {
  // The cubic spline pairs past a support of 2 spacings (kCubicPairingSupport's measurements);
  // the other kernels do not, and no shipped scene asks for it but the DualSPHysics column
  // (scenes/bench: DualSPHysics's own cubic spline at h = 1.732 dp, kept to measure speed at
  // DualSPHysics's particle and neighbour counts).
  const std::string dam = (test::source_dir() / "scenes" / "dambreak.toml").string();
  EXPECT_TRUE(scene_cautions(load_scene(dam)).empty()) << "cubic at 2 spacings";
  const auto c = scene_cautions(load_scene(dam, {"fluid.support=2.25"}));
  ASSERT_EQ(c.size(), 1u);
  for (const char* says : {"dambreak.toml", "fluid.support = 2.25", "\"wendland\""})
    EXPECT_NE(c[0].find(says), std::string::npos) << says << " in: " << c[0];
  for (const char* kernel : {"\"wendland\"", "\"spiky\""})
    EXPECT_TRUE(scene_cautions(
                    load_scene(dam, {"fluid.support=3.0", std::string("solver.kernel=") + kernel}))
                    .empty())
        << kernel;
  int scenes = 0;
  for (const auto& e :
       std::filesystem::recursive_directory_iterator(test::source_dir() / "scenes")) {
    if (e.path().extension() != ".toml" || e.path().parent_path().filename() == "bench")
      continue;
    EXPECT_TRUE(scene_cautions(load_scene(e.path().string())).empty()) << e.path();
    ++scenes;
  }
  EXPECT_GE(scenes, 15);
}

TEST(Scene, MeshObstacleReadsItsKeysAndLoadsTheMesh) {
  const Scene s = load_scene(scene_file("mesh.toml"));
  ASSERT_EQ(s.obstacles.size(), 2u);
  const Obstacle& crate = s.obstacles[0];
  EXPECT_EQ(crate.shape, ObstacleShape::Mesh);
  EXPECT_EQ(crate.name, "crate");
  // Relative to the scene file's directory.
  EXPECT_EQ(crate.file, (test::data_dir() / "meshes" / "cube.obj").lexically_normal().string());
  EXPECT_DOUBLE_EQ(crate.scale, 0.25);
  expect_vec(crate.translate, 0.5, 0.25, 0);
  expect_vec(crate.velocity, 0, 0, 0.1);
  ASSERT_TRUE(crate.mesh);
  EXPECT_EQ(crate.mesh->solid.triangles.size(), 12u); // six quads, fan-triangulated
  EXPECT_NEAR(crate.mesh->solid.volume, 0.25 * 0.25 * 0.25, 1e-15);
  expect_vec(crate.mesh->solid.lo, 0.5, 0.25, 0);
  EXPECT_FALSE(crate.mesh->sdf.values.empty());
  const Obstacle& plain = s.obstacles[1];
  EXPECT_EQ(plain.name, "obstacle[1]");
  EXPECT_DOUBLE_EQ(plain.scale, 1);
  expect_vec(plain.translate, 0, 0, 0);
  EXPECT_NEAR(plain.mesh->solid.volume, 1, 1e-15);
}

TEST(Scene, KnitMeshPieceReadsItsKeysAndLoadsTheQuads) {
  const Scene s = load_scene(scene_file("knit_mesh.toml"));
  ASSERT_EQ(s.knit.pieces.size(), 2u);
  const KnitPiece& sheet = s.knit.pieces[0];
  EXPECT_EQ(sheet.shape, KnitShape::Mesh);
  EXPECT_EQ(sheet.name, "sheet");
  // Relative to the scene file's directory.
  EXPECT_EQ(sheet.file,
            (test::data_dir() / "meshes" / "knit_sheet.obj").lexically_normal().string());
  EXPECT_DOUBLE_EQ(sheet.scale, 0.1);
  expect_vec(sheet.translate, 0.1, 0.2, 0.3);
  expect_vec(sheet.velocity, 0, 0, -1);
  ASSERT_TRUE(sheet.mesh);
  EXPECT_EQ(sheet.mesh->quads.size(), 2u);
  ASSERT_EQ(sheet.mesh->vertices.size(), 6u);
  expect_vec(sheet.mesh->vertices[5], 0.1 + 0.2, 0.2 + 0.1, 0.3); // (2, 1, 0) * 0.1 + translate
  expect_vec(sheet.mesh->normals[0], 0, 0, 1);                    // counter-clockwise seen from +z
  const KnitPiece& plain = s.knit.pieces[1];
  EXPECT_EQ(plain.name, "knit.piece[1]");
  EXPECT_DOUBLE_EQ(plain.scale, 1);
  expect_vec(plain.translate, 0, 0, 0);
  EXPECT_EQ(to_string(KnitShape::Mesh), "mesh");
}

TEST(Scene, MeshFileOfATextSceneIsRelativeToTheWorkingDirectory) {
  const auto dir = test::scratch_dir("scene_mesh_cwd");
  std::filesystem::copy_file(test::data_dir() / "meshes" / "cube.obj", dir / "box.obj");
  const auto cwd = std::filesystem::current_path();
  std::filesystem::current_path(dir);
  const std::string text = "[simulation]\nend_time = 1\nmodules = [\"boundary\"]\n"
                           "[domain]\nmin = [0, 0, 0]\nmax = [2, 2, 2]\n"
                           "[[obstacle]]\nshape = \"mesh\"\nfile = \"box.obj\"\n";
  std::string error;
  Scene s;
  try {
    s = parse_scene(text, "<string>");
  } catch (const Error& e) {
    error = e.what();
  }
  std::filesystem::current_path(cwd);
  ASSERT_EQ(error, "");
  EXPECT_EQ(s.obstacles.at(0).file, "box.obj");
  EXPECT_NEAR(s.obstacles[0].mesh->solid.volume, 1, 1e-15);
}

TEST(Scene, ToStringUsesSceneSpelling) {
  EXPECT_EQ(to_string(KernelType::CubicSpline), "cubic");
  EXPECT_EQ(to_string(EosType::Linear), "linear");
  EXPECT_EQ(to_string(Module::Boundary), "boundary");
  EXPECT_EQ(to_string(ObstacleShape::Sphere), "sphere");
  EXPECT_EQ(to_string(ObstacleShape::Mesh), "mesh");
}

TEST(Scene, MissingFileNamesPath) {
  const std::string path = scene_file("no/such/scene.toml");
  const std::string msg = load_error(path);
  EXPECT_NE(msg.find(path + ": cannot open scene file"), std::string::npos) << msg;
  EXPECT_NE(msg.find("No such file or directory"), std::string::npos) << msg;
}

TEST(Scene, SyntaxErrorInTextNamesSource) {
  try {
    parse_scene("[simulation]\nend_time = [1,\n", "<string>");
    FAIL() << "no SceneError";
  } catch (const SceneError& e) {
    EXPECT_NE(std::string(e.what()).find("<string>:"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("TOML syntax error"), std::string::npos) << e.what();
  }
}

// A broken scene file, the line its error must name, the key (none for syntax errors), and what
// the message must say.
struct Broken {
  const char* file;
  int line;
  const char* key;
  const char* says;
};

// clang-format off
const Broken kBroken[] = {
  {"syntax_error", 3, "", ":3:12: TOML syntax error"},
  {"unknown_key", 11, "fluid.spaceing", "unknown key 'fluid.spaceing' (did you mean 'spacing'?)"},
  {"unknown_table", 17, "sovler", "unknown table 'sovler' (did you mean 'solver'?)"},
  {"unknown_table_case", 6, "Domain", "(did you mean 'domain'?)"},
  {"wrong_type", 11, "fluid.spacing", "expected a number, got a string (\"abc\")"},
  {"negative_spacing", 11, "fluid.spacing", "expected a number > 0, got -0.01"},
  {"nan_value", 12, "fluid.viscosity", "expected a finite number, got nan"},
  {"inf_in_vector", 7, "domain.min[2]", "expected a finite number, got -inf"},
  {"domain_max_le_min", 8, "domain.max", "expected every component > domain.min [0, 0, 0], got [1, 0, 1]"},
  {"block_outside_domain", 15, "fluid.block[0].max", "expected a point inside the domain"},
  {"missing_required", 6, "domain", "table 'domain': missing required key 'max'"},
  {"missing_simulation", 1, "simulation", "table 'simulation': missing required key 'end_time'"},
  {"unknown_module", 4, "simulation.modules[2]", "expected one of \"fluid\", \"boundary\", \"knit\", \"contact\", \"capillary\", got \"rendering\""},
  {"knit_without_pieces", 10, "knit.piece", "expected at least one [[knit.piece]]"},
  {"knit_tube_with_width", 14, "knit.piece[0]", "unknown key 'knit.piece[0].width'"},
  {"knit_zero_wales", 13, "knit.piece[0].wales", "expected an integer >= 1, got 0"},
  {"parallel_block_cells_zero", 15, "parallel.block_cells", "expected an integer >= 1, got 0"},
  {"knit_pin_inverted", 16, "knit.pin[0].max", "expected every component > knit.pin[0].min"},
  {"duplicate_module", 4, "simulation.modules[2]", "at most once"},
  {"fluid_without_boundary", 4, "simulation.modules", "module \"fluid\" requires module \"boundary\""},
  {"blocks_without_fluid", 13, "fluid.block", "module \"fluid\" is not in simulation.modules"},
  {"fluid_without_blocks", 10, "fluid.block", "expected at least one [[fluid.block]]"},
  {"obstacle_key_for_other_shape", 21, "obstacle[0]", "key 'radius' does not apply to shape 'box'"},
  {"obstacle_missing_shape", 17, "obstacle[0]", "missing required key 'shape'"},
  {"sphere_radius_zero", 20, "obstacle[0].radius", "expected a number > 0, got 0"},
  {"plane_zero_normal", 20, "obstacle[0].normal", "expected a non-zero vector"},
  {"dt_min_ge_dt_max", 19, "solver.dt_min", "expected a number < solver.dt_max"},
  {"bad_kernel", 18, "solver.kernel", "expected one of \"spiky\", \"cubic\", \"wendland\", got \"gaussian\""},
  {"kernel_typo", 18, "solver.kernel", "got \"cubc\" (did you mean 'cubic'?)"},
  {"stiffness_and_sound", 14, "fluid.stiffness", "either stiffness or speed_of_sound, not both"},
  {"stiffness_with_tait", 13, "fluid.stiffness", "no stiffness with eos = \"tait\""},
  {"gravity_two_components", 5, "simulation.gravity", "expected an array of 3 numbers"},
  {"bad_wall", 9, "domain.walls[1]", "got \"bottom\""},
  {"support_out_of_range", 12, "fluid.support", "expected a number in [1, 4], got 5"},
  {"cfl_zero", 18, "solver.cfl", "expected a number in (0, 1], got 0"},
  {"max_steps_float", 18, "solver.max_steps", "expected an integer >= 0, got a number (1.5)"},
  {"end_time_negative", 3, "simulation.end_time", "expected a number > 0, got -1"},
  {"output_dir_empty", 18, "output.dir", "expected a non-empty string"},
  {"block_not_array", 13, "fluid.block", "expected an array of tables ([[fluid.block]])"},
  {"mesh_not_closed", 19, "obstacle[0].file", "meshes/open_cube.obj' is not closed: edge (5, 6) belongs to 1 face (" },
  {"mesh_not_oriented", 19, "obstacle[0].file", "meshes/flipped_cube.obj' is not consistently oriented: edge (5, 6) runs the same way in its faces on "},
  {"mesh_bad_obj", 19, "obstacle[0].file", "meshes/bad_number.obj:4: vertex: expected a number, got 'O'"},
  {"mesh_missing_file", 19, "obstacle[0].file", "meshes/no_such_mesh.obj: cannot open OBJ file (No such file or directory)"},
  {"mesh_scale_zero", 20, "obstacle[0].scale", "expected a number > 0, got 0"},
  {"mesh_without_file", 17, "obstacle[0]", "table 'obstacle[0]': missing required key 'file'"},
  {"mesh_with_radius", 20, "obstacle[0]", "key 'radius' does not apply to shape 'mesh' (a mesh takes file, scale, translate)"},
  {"knit_mesh_triangle", 12, "knit.piece[0].file", "meshes/knit_with_triangle.obj' is not a quad mesh: the face on "},
  {"knit_mesh_not_manifold", 12, "knit.piece[0].file", "meshes/knit_fin.obj' is not a manifold: edge (2, 5) belongs to 3 faces ("},
  {"knit_mesh_not_oriented", 12, "knit.piece[0].file", "meshes/knit_flipped.obj' is not consistently oriented: edge (2, 5) runs the same way in its faces on "},
  {"knit_mesh_missing_file", 12, "knit.piece[0].file", "meshes/no_such_sleeve.obj: cannot open OBJ file (No such file or directory)"},
  {"knit_mesh_with_wales", 13, "knit.piece[0]", "key 'wales' does not apply to shape 'mesh' (a mesh takes file, scale, translate, besides name and velocity)"},
  {"knit_mesh_without_file", 10, "knit.piece[0]", "table 'knit.piece[0]': missing required key 'file'"},
  {"knit_mesh_outside_domain", 12, "knit.piece[0].file", "expected a mesh inside the domain [-1, -1, -1]..[1, 1, 1] (after scale and translate), got one spanning [0, 0, 5]..[2, 1, 5]"},
  {"knit_mesh_key_typo", 13, "knit.piece[0].scael", "unknown key 'knit.piece[0].scael' (did you mean 'scale'?)"},
};
// clang-format on

class BrokenScene : public ::testing::TestWithParam<Broken> {};

TEST_P(BrokenScene, FailsNamingFileLineAndKey) {
  const Broken& b = GetParam();
  const std::string file = std::string(b.file) + ".toml";
  const std::string path = scene_file("broken/" + file);
  EXPECT_THROW(load_scene(path), SceneError);
  const std::string msg = load_error(path);
  EXPECT_EQ(msg.rfind(path + ":" + std::to_string(b.line) + ":", 0), 0u) << msg;
  if (*b.key) {
    EXPECT_NE(msg.find("'" + std::string(b.key)), std::string::npos) << msg;
  }
  EXPECT_NE(msg.find(b.says), std::string::npos) << msg;
  EXPECT_EQ(msg.find('\n'), std::string::npos) << "not one line: " << msg;
}

INSTANTIATE_TEST_SUITE_P(Files, BrokenScene, ::testing::ValuesIn(kBroken),
                         [](const auto& info) { return std::string(info.param.file); });

// An override that is malformed or names something that is not there; what the message must say.
struct BadOverride {
  const char* set;
  const char* says;
};

// clang-format off
const BadOverride kBadOverrides[] = {
  {"fluid.spaceing=0.02", "--set fluid.spaceing=0.02: unknown key 'fluid.spaceing' (did you mean 'spacing'?)"},
  {"fluidd.spacing=0.02", "--set fluidd.spacing=0.02: unknown table 'fluidd' (did you mean 'fluid'?)"},
  {"fluid.spacing", "--set fluid.spacing: malformed override: expected KEY=VALUE"},
  {"=0.02", "--set =0.02: malformed override: expected a key"},
  {"fluid.spacing=", "--set fluid.spacing=: malformed override: expected a value"},
  {"fluid..spacing=1", "--set fluid..spacing=1: malformed override"},
  {"fluid.spacing=-1", "--set fluid.spacing=-1: key 'fluid.spacing': expected a number > 0, got -1"},
  {"fluid.spacing=abc", "--set fluid.spacing=abc: key 'fluid.spacing': expected a number, got a string (\"abc\")"},
  {"fluid.block.3.velocity=[1,0,0]", "--set fluid.block.3.velocity=[1,0,0]: key 'fluid.block': expected an element index 0..0, got '3'"},
  {"fluid.block.x.velocity=[1,0,0]", "key 'fluid.block': expected an element index"},
  {"solver.kernel=gaussian", "--set solver.kernel=gaussian: key 'solver.kernel': expected one of"},
  {"render.eye=[1,1,1]", "table 'render': missing required key 'target'"},
  {"render.fluid_colour=[2,0,0]", "key 'render.fluid_colour': expected a colour: three numbers in [0, 1] (linear RGB), got [2, 0, 0]"},
  {"render.fluid=\"blobs\"", "key 'render.fluid': expected one of \"surface\", \"spheres\", got \"blobs\""},
  {"render.widht=100", "unknown key 'render.widht' (did you mean 'width'?)"},
  {"render.width=8", "key 'render.width': expected an integer >= 16, got 8"},
  {"render.knit=\"tubes\"", "key 'render.knit': expected one of \"yarns\", \"points\", got \"tubes\""},
};
// clang-format on

class BadOverrideTest : public ::testing::TestWithParam<BadOverride> {};

TEST_P(BadOverrideTest, Fails) {
  const std::string msg = load_error(scene_file("minimal.toml"), {GetParam().set});
  EXPECT_NE(msg.find(GetParam().says), std::string::npos) << msg;
}

INSTANTIATE_TEST_SUITE_P(Overrides, BadOverrideTest, ::testing::ValuesIn(kBadOverrides));

TEST(Scene, OverrideErrorNamesTheOverrideNotTheFile) {
  // The file is valid; the value the override puts there is not.
  const std::string msg = load_error(scene_file("full.toml"), {"obstacle.1.radius=0.1"});
  EXPECT_EQ(msg.rfind("--set obstacle.1.radius=0.1: table 'obstacle[1]': key 'radius' does not "
                      "apply to shape 'box'",
                      0),
            0u)
      << msg;
}

TEST(Scene, NeighbourSearchOptions) {
  const Scene d = load_scene(scene_file("minimal.toml"));
  EXPECT_EQ(d.solver.cell_span, 1);
  EXPECT_EQ(d.solver.neighbour_list, Scene::Solver::NeighbourLists::Off);
  const Scene s = load_scene(scene_file("minimal.toml"),
                             {"solver.cell_span=2", "solver.neighbour_list=\"on\""});
  EXPECT_EQ(s.solver.cell_span, 2);
  EXPECT_EQ(s.solver.neighbour_list, Scene::Solver::NeighbourLists::On);
  const std::string span = load_error(scene_file("minimal.toml"), {"solver.cell_span=4"});
  EXPECT_NE(span.find("key 'solver.cell_span': expected an integer from 1 to 3, got 4"),
            std::string::npos)
      << span;
  EXPECT_EQ(d.solver.cell_order, 2);
  EXPECT_EQ(load_scene(scene_file("minimal.toml"), {"solver.cell_order=0"}).solver.cell_order, 0);
  const std::string order = load_error(scene_file("minimal.toml"), {"solver.cell_order=3"});
  EXPECT_NE(order.find("key 'solver.cell_order': expected an integer from 0 to 2, got 3"),
            std::string::npos)
      << order;
  const std::string list = load_error(scene_file("minimal.toml"), {"solver.neighbour_list=yes"});
  EXPECT_NE(list.find("solver.neighbour_list"), std::string::npos) << list;
  EXPECT_NE(list.find("\"on\""), std::string::npos) << list;
}

TEST(Scene, ArtificialViscosity) {
  EXPECT_EQ(load_scene(scene_file("minimal.toml")).fluid.artificial_viscosity, 0.0);
  const Scene s = load_scene(scene_file("minimal.toml"), {"fluid.artificial_viscosity=0.01"});
  EXPECT_DOUBLE_EQ(s.fluid.artificial_viscosity, 0.01);
  const std::string e = load_error(scene_file("minimal.toml"), {"fluid.artificial_viscosity=-1"});
  EXPECT_NE(e.find("key 'fluid.artificial_viscosity': expected a number in [0, 1]"),
            std::string::npos)
      << e;
}

TEST(Scene, ShiftingOptions) {
  const Scene d = load_scene(scene_file("minimal.toml"));
  EXPECT_EQ(d.solver.shifting, Scene::Solver::Shifting::Off);
  const Scene s = load_scene(scene_file("minimal.toml"),
                             {"solver.shifting=\"fickian\"", "solver.shifting_coefficient=4",
                              "solver.shifting_surface=1.5"});
  EXPECT_EQ(s.solver.shifting, Scene::Solver::Shifting::Fickian);
  EXPECT_DOUBLE_EQ(s.solver.shifting_coefficient, 4.0);
  EXPECT_DOUBLE_EQ(s.solver.shifting_surface, 1.5);
  const std::string kind = load_error(scene_file("minimal.toml"), {"solver.shifting=\"on\""});
  EXPECT_NE(kind.find("solver.shifting"), std::string::npos) << kind;
  EXPECT_NE(kind.find("\"fickian\""), std::string::npos) << kind;
  const std::string a = load_error(scene_file("minimal.toml"), {"solver.shifting_coefficient=0"});
  EXPECT_NE(a.find("key 'solver.shifting_coefficient'"), std::string::npos) << a;
  const std::string surface =
      load_error(scene_file("minimal.toml"), {"solver.shifting_surface=3.5"});
  EXPECT_NE(surface.find("key 'solver.shifting_surface'"), std::string::npos) << surface;
}

TEST(Scene, DensityModelOptions) {
  const Scene d = load_scene(scene_file("minimal.toml"));
  EXPECT_EQ(d.solver.density, DensityModel::Summation);
  EXPECT_DOUBLE_EQ(d.solver.density_diffusion, 0.1);
  const Scene s = load_scene(scene_file("minimal.toml"),
                             {"solver.density=\"continuity\"", "solver.density_diffusion=0.05"});
  EXPECT_EQ(s.solver.density, DensityModel::Continuity);
  EXPECT_DOUBLE_EQ(s.solver.density_diffusion, 0.05);
  const std::string model = load_error(scene_file("minimal.toml"), {"solver.density=\"sum\""});
  EXPECT_NE(model.find("solver.density"), std::string::npos) << model;
  EXPECT_NE(model.find("\"continuity\""), std::string::npos) << model;
  const std::string delta = load_error(scene_file("minimal.toml"), {"solver.density_diffusion=-1"});
  EXPECT_NE(delta.find("solver.density_diffusion"), std::string::npos) << delta;
  const Scene h = load_scene(scene_file("minimal.toml"), {"solver.density=\"continuity\"",
                                                          "fluid.initial_density=\"hydrostatic\""});
  EXPECT_EQ(h.fluid.initial_density, Scene::Fluid::InitialDensity::Hydrostatic);
  const std::string start =
      load_error(scene_file("minimal.toml"), {"fluid.initial_density=\"weight\""});
  EXPECT_NE(start.find("fluid.initial_density"), std::string::npos) << start;
  EXPECT_NE(start.find("\"hydrostatic\""), std::string::npos) << start;
}

} // namespace
TEST(Scene, RenderTableReadsItsKeys) {
  const Scene s = load_scene(
      (test::source_dir() / "scenes" / "pour.toml").string(),
      {"render.width=640", "render.orbit=30", "render.fluid=\"spheres\"",
       "render.surface=\"naive\"", "render.knit_colour=[0.1, 0.2, 0.3]", "render.knit=\"points\"",
       "render.yarn_radius=0.001", "render.shadows=false", "render.refraction=false",
       "render.refractive_index=1.5", "render.absorption_depth=0.25", "render.yarn_volume=false",
       "render.yarn_plies=2", "render.yarn_fuzz=0", "render.yarn_slices=3",
       "render.yarn_detail_pixels=2.5", "render.surface_cell=2"});
  EXPECT_EQ(s.render.width, 640);
  EXPECT_EQ(s.render.height, 1080); // scenes/pour.toml's own
  EXPECT_TRUE(s.render.camera);
  EXPECT_DOUBLE_EQ(s.render.orbit, 30);
  EXPECT_EQ(s.render.fluid, Scene::Render::Fluid::Spheres);
  EXPECT_EQ(s.render.surface, Scene::Render::SurfaceField::Naive);
  EXPECT_DOUBLE_EQ(s.render.knit_colour.y, 0.2);
  EXPECT_EQ(s.render.knit, Scene::Render::Knit::Points);
  EXPECT_DOUBLE_EQ(s.render.yarn_radius, 0.001);
  EXPECT_FALSE(s.render.shadows);
  EXPECT_TRUE(s.render.floor);
  EXPECT_FALSE(s.render.refraction);
  EXPECT_DOUBLE_EQ(s.render.refractive_index, 1.5);
  EXPECT_DOUBLE_EQ(s.render.absorption_depth, 0.25);
  EXPECT_FALSE(s.render.yarn_volume);
  EXPECT_EQ(s.render.yarn_plies, 2);
  EXPECT_EQ(s.render.yarn_fuzz, 0);
  EXPECT_EQ(s.render.yarn_slices, 3);
  EXPECT_DOUBLE_EQ(s.render.yarn_detail_pixels, 2.5);
  EXPECT_DOUBLE_EQ(s.render.surface_cell, 2);
  // An index below air's, or water that absorbs all at no depth, named with what it needs.
  for (const char* bad :
       {"render.refractive_index=0.5", "render.absorption_depth=0", "render.yarn_slices=5",
        "render.yarn_plies=0", "render.yarn_detail_pixels=-1", "render.surface_cell=0"}) {
    const std::string e = load_error((test::source_dir() / "scenes" / "pour.toml").string(), {bad});
    EXPECT_NE(e.find(std::string(bad).substr(0, std::string(bad).find('='))), std::string::npos)
        << e;
  }
  const Scene plain = load_scene((test::source_dir() / "scenes" / "dambreak.toml").string());
  EXPECT_FALSE(plain.render.camera);
  EXPECT_EQ(plain.render.width, 1280);
}

TEST(Scene, PourTomlShowsEveryRenderKeyAtItsDefault) {
  // The README sends users to scenes/pour.toml for the [render] keys: each key the loader takes
  // is there, set or commented out at its default. Uncommented, the defaults change nothing.
  const std::filesystem::path path = test::source_dir() / "scenes" / "pour.toml";
  std::ifstream in(path);
  ASSERT_TRUE(in) << path;
  std::string text, line, uncommented;
  std::vector<std::string> listed;
  bool in_render = false;
  while (std::getline(in, line)) {
    text += line + "\n";
    if (!line.empty() && line[0] == '[')
      in_render = line.rfind("[render]", 0) == 0;
    std::smatch m;
    if (in_render && std::regex_search(line, m, std::regex(R"(^(# )?([a-z_]+) = )"))) {
      listed.push_back(m[2]);
      if (m[1].matched)
        line = line.substr(2);
    }
    uncommented += line + "\n";
  }
  std::vector<std::string> keys(render_table_keys().begin(), render_table_keys().end());
  std::sort(keys.begin(), keys.end());
  std::sort(listed.begin(), listed.end());
  EXPECT_EQ(listed, keys);
  const Scene::Render a = parse_scene(text, path.string()).render,
                      b = parse_scene(uncommented, path.string()).render;
  const auto same3 = [](const Vec3d& p, const Vec3d& q) {
    return p.x == q.x && p.y == q.y && p.z == q.z;
  };
#define KF_SAME(f) EXPECT_EQ(a.f, b.f) << #f
#define KF_SAME3(f) EXPECT_TRUE(same3(a.f, b.f)) << #f
  KF_SAME(width);
  KF_SAME(height);
  KF_SAME(camera);
  KF_SAME3(eye);
  KF_SAME3(target);
  KF_SAME(fov);
  KF_SAME(orbit);
  KF_SAME3(light);
  KF_SAME(ambient);
  KF_SAME(highlights);
  KF_SAME3(background);
  KF_SAME3(fluid_colour);
  KF_SAME3(knit_colour);
  KF_SAME(wet_darkening);
  KF_SAME(fluid);
  KF_SAME(surface);
  KF_SAME(surface_cell);
  KF_SAME(boundary);
  KF_SAME(knit);
  KF_SAME(yarn_radius);
  KF_SAME(yarn_volume);
  KF_SAME(yarn_plies);
  KF_SAME(yarn_fuzz);
  KF_SAME(yarn_slices);
  KF_SAME(yarn_detail_pixels);
  KF_SAME(shadows);
  KF_SAME(floor);
  KF_SAME(tank);
  KF_SAME(reflections);
  KF_SAME(environment_map);
  KF_SAME(refraction);
  KF_SAME(refractive_index);
  KF_SAME(absorption_depth);
  KF_SAME(gpu_geometry);
#undef KF_SAME
#undef KF_SAME3
  // (A check that can fail: a default written wrong in the file shows as a difference.)
  const std::string wrong =
      std::regex_replace(uncommented, std::regex("yarn_fuzz = 40"), "yarn_fuzz = 41");
  EXPECT_NE(parse_scene(wrong, path.string()).render.yarn_fuzz, a.yarn_fuzz);
}

TEST(Scene, ASnapshotsCopyFindsItsFilesWhereTheRunFoundThem) {
  // A snapshot holds its run's scene text; rendered from the output folder, the OBJ it names
  // (relative to the scene file) is found through the folder the run recorded, not beside the
  // snapshot.
  const std::filesystem::path dir = test::source_dir() / "scenes";
  const Scene run = load_scene((dir / "mesh_obstacle.toml").string());
  EXPECT_EQ(run.files_dir, std::filesystem::absolute(dir).lexically_normal().string());
  const std::string as_copy = "/tmp/out/frame_000000.h5 (its scene)";
  try {
    (void)parse_scene(run.text, as_copy);
    ADD_FAILURE() << "the OBJ was found beside the snapshot";
  } catch (const SceneError& e) {
    EXPECT_NE(std::string(e.what()).find("obstacle[0].file"), std::string::npos) << e.what();
  }
  const Scene copy = parse_scene(run.text, as_copy, {}, run.files_dir);
  ASSERT_EQ(copy.obstacles.size(), run.obstacles.size());
  EXPECT_EQ(std::filesystem::path(copy.obstacles[0].file),
            std::filesystem::absolute(dir / "meshes" / "blob.obj").lexically_normal());
  EXPECT_EQ(copy.files_dir, run.files_dir);
}

TEST(Scene, AColourChartNamesItsLettersColours) {
  const std::string head = "[simulation]\nend_time = 1\nmodules = [\"knit\"]\n"
                           "[domain]\nmin = [-1, -1, -1]\nmax = [1, 1, 1]\n"
                           "[[knit.piece]]\nshape = \"patch\"\ncenter = [0, 0, 0]\n";
  const Scene s = parse_scene(
      head + "colours = { A = [0.8, 0.1, 0.1], B = [0.9, 0.9, 0.85] }\ncolour_chart = [\"AB\"]\n",
      "<string>");
  const KnitPiece& k = s.knit.pieces.at(0);
  EXPECT_EQ(k.colour_chart, std::vector<std::string>{"AB"});
  ASSERT_EQ(k.colours.size(), 2u);
  EXPECT_DOUBLE_EQ(k.colours.at('A').x, 0.8);
  EXPECT_DOUBLE_EQ(k.colours.at('B').z, 0.85);
  // Each mistake named with its key and what was expected.
  const std::pair<std::string, std::string> bad[] = {
      {"colours = { A = [1, 0, 0] }\ncolour_chart = [\"AC\"]\n", "colour_chart[0]"},
      {"colours = { A = [1, 0, 2] }\ncolour_chart = [\"A\"]\n", "colours.A"},
      {"colours = { AB = [1, 0, 0] }\ncolour_chart = [\"A\"]\n", "colours.AB"},
      {"colour_chart = [\"A\"]\n", "colour_chart"},
      {"colours = { A = [1, 0, 0] }\n", "colour_chart"},
      {"colours = { A = [1, 0, 0] }\ncolour_chart = [\"AA\", \"A\"]\n", "colour_chart[1]"}};
  for (const auto& [text, key] : bad) {
    std::string error;
    try {
      parse_scene(head + text, "<string>");
    } catch (const SceneError& e) {
      error = e.what();
    }
    EXPECT_NE(error.find(key), std::string::npos) << text << " -> " << error;
  }
}

TEST(Scene, QualityPresetsScaleTheSpacingAndFillWhatTheSceneLeavesOut) {
  const Scene plain = load_scene(scene_file("minimal.toml"));
  EXPECT_EQ(plain.solver.quality, Scene::Solver::Quality::None);
  // "production" is the scene as written.
  const Scene production =
      load_scene(scene_file("minimal.toml"), {"solver.quality=\"production\""});
  EXPECT_DOUBLE_EQ(production.fluid.spacing, plain.fluid.spacing);
  EXPECT_DOUBLE_EQ(production.solver.cfl, plain.solver.cfl);
  // "preview": twice the spacing and its own settings; a key the scene gives wins.
  const Scene preview = load_scene(scene_file("minimal.toml"), {"solver.quality=\"preview\""});
  const QualityPreset p = quality_preset(Scene::Solver::Quality::Preview);
  EXPECT_DOUBLE_EQ(preview.fluid.spacing, p.spacing_scale * plain.fluid.spacing);
  EXPECT_DOUBLE_EQ(preview.solver.cfl, *p.cfl);
  EXPECT_EQ(preview.solver.density, *p.density);
  EXPECT_EQ(preview.solver.neighbour_list, *p.neighbour_list);
  const Scene mine =
      load_scene(scene_file("minimal.toml"),
                 {"solver.quality=\"preview\"", "solver.cfl=0.15", "solver.density=\"summation\""});
  EXPECT_DOUBLE_EQ(mine.solver.cfl, 0.15);
  EXPECT_EQ(mine.solver.density, DensityModel::Summation);
  EXPECT_DOUBLE_EQ(mine.fluid.spacing, p.spacing_scale * plain.fluid.spacing);
  // "reference": half the spacing, twice the speed of sound; the rest as written.
  const Scene reference = load_scene(scene_file("minimal.toml"), {"solver.quality=\"reference\""});
  EXPECT_DOUBLE_EQ(reference.fluid.spacing, 0.5 * plain.fluid.spacing);
  EXPECT_DOUBLE_EQ(reference.fluid.speed_of_sound, 2 * plain.fluid.speed_of_sound);
  EXPECT_DOUBLE_EQ(reference.solver.cfl, plain.solver.cfl);
  EXPECT_EQ(reference.precision, plain.precision);
  EXPECT_EQ(to_string(Scene::Solver::Quality::Reference), "reference");
  const std::string bad = load_error(scene_file("minimal.toml"), {"solver.quality=\"best\""});
  EXPECT_NE(bad.find("solver.quality"), std::string::npos) << bad;
  EXPECT_NE(bad.find("\"preview\""), std::string::npos) << bad;
}

} // namespace kf
