// The knitflow command: broken scenes fail with their message and exit code 2 and write nothing;
// plan prints the pipeline without running; run writes snapshots and an XDMF index.
#include "support/TestPaths.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <string>

namespace fs = std::filesystem;
using namespace kf;

namespace {

struct Result {
  int code;
  std::string output;
};

Result run(const std::string& args, const fs::path& cwd = {}) {
  const std::string cd = cwd.empty() ? "" : "cd '" + cwd.string() + "' && ";
  const std::string cmd = cd + test::knitflow_exe().string() + " " + args + " 2>&1";
  FILE* p = popen(cmd.c_str(), "r");
  std::string out;
  std::array<char, 4096> buf{};
  while (fgets(buf.data(), buf.size(), p))
    out += buf.data();
  const int status = pclose(p);
  return {WEXITSTATUS(status), out};
}

} // namespace

TEST(Cli, BrokenScenesFailWithTheirMessageAndWriteNothing) {
  // Each runs from an empty directory with the scene's own output settings; nothing may appear.
  const auto cwd = test::scratch_dir("cli_broken");
  int checked = 0;
  for (const auto& e : fs::directory_iterator(test::data_dir() / "scenes" / "broken")) {
    if (e.path().extension() != ".toml")
      continue;
    const Result r = run("run " + e.path().string() + " --quiet", cwd);
    EXPECT_EQ(r.code, 2) << e.path() << "\n" << r.output;
    EXPECT_NE(r.output.find("knitflow: error: "), std::string::npos) << r.output;
    EXPECT_NE(r.output.find(e.path().filename().string()), std::string::npos)
        << "message must name the file: " << r.output;
    EXPECT_TRUE(fs::is_empty(cwd)) << e.path() << " wrote output";
    ++checked;
  }
  EXPECT_GE(checked, 10);
}

TEST(Cli, UnknownOverrideFailsBeforeOutput) {
  const auto out = test::scratch_dir("cli_override") / "out";
  const Result r = run("run " + (test::source_dir() / "scenes/hydrostatic.toml").string() +
                       " --set fluid.spaceing=0.02 --quiet --output " + out.string());
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.output.find("did you mean 'spacing'"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(out));
}

TEST(Cli, PlanPrintsStagesWithoutRunning) {
  const Result r = run("plan " + (test::source_dir() / "scenes/dambreak.toml").string());
  EXPECT_EQ(r.code, 0) << r.output;
  for (const char* s : {"sph.density", "sph.forces", "boundary.pressure", "particles", "dt"})
    EXPECT_NE(r.output.find(s), std::string::npos) << s << " missing from:\n" << r.output;
}

TEST(Cli, PlanDescribesAMeshObstacle) {
  const Result r = run("plan " + (test::source_dir() / "scenes/mesh_obstacle.toml").string());
  EXPECT_EQ(r.code, 0) << r.output;
  for (const char* s : {"obstacle   blob: mesh ", "meshes/blob.obj, 1280 triangles",
                        "distance sampled on", "solids "})
    EXPECT_NE(r.output.find(s), std::string::npos) << s << " missing from:\n" << r.output;
}

TEST(Cli, RunWritesSnapshotsAndIndex) {
  const auto out = test::scratch_dir("cli_run") / "out";
  const Result r =
      run("run " + (test::source_dir() / "scenes/hydrostatic.toml").string() +
          " --set simulation.end_time=0.01 --set output.interval=0.005 --output " + out.string());
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_TRUE(fs::exists(out / "frame_000000.h5"));
  EXPECT_TRUE(fs::exists(out / "frame_000002.h5"));
  EXPECT_TRUE(fs::exists(out / "snapshots.xmf"));
  EXPECT_NE(r.output.find("done:"), std::string::npos) << r.output;
  // Restart from frame 1 continues to the end.
  const Result r2 =
      run("run " + (test::source_dir() / "scenes/hydrostatic.toml").string() +
          " --set simulation.end_time=0.01 --set output.interval=0.005 --quiet --output " +
          out.string() + " --restart " + (out / "frame_000001.h5").string());
  EXPECT_EQ(r2.code, 0) << r2.output;
}
