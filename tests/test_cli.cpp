// The knitflow command: broken scenes fail with their message and exit code 2 and write nothing;
// plan prints the pipeline without running; run writes snapshots and an XDMF index.
#include "io/PngImage.hpp"
#include "io/SnapshotReader.hpp"
#include "io/SnapshotWriter.hpp"
#include "support/RunKnitflow.hpp"
#include "support/TestPaths.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <sstream>
#include <string>

namespace fs = std::filesystem;
using namespace kf;

namespace {

using Result = test::CliResult;

Result run(const std::string& args, const fs::path& cwd = {}) {
  return test::run_knitflow(args, cwd);
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

// `plan --ranks N`: every fluid particle owned by one rank (the scene's 20 x 20 x 40 column),
// each rank's grids a window of the domain's cells, the rank holding the column's blocks a small
// one (the dam break on 4 ranks: 14-23% for the three that share the column, measured).
TEST(Cli, PlanWithRanksSharesTheParticlesAndShrinksTheGrids) {
  const Result r =
      run("plan " + (test::source_dir() / "scenes/dambreak.toml").string() + " --ranks 4");
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("each rank's a window of the domain's"), std::string::npos) << r.output;
  std::istringstream in(r.output);
  std::string line;
  int rows = 0;
  long fluid = 0;
  double smallest = 101;
  while (std::getline(in, line)) {
    int rank = -1;
    long f = 0, b = 0, k = 0;
    if (std::sscanf(line.c_str(), " %d %ld %ld %ld |", &rank, &f, &b, &k) != 4 ||
        line.find('|') == std::string::npos)
      continue;
    ++rows;
    fluid += f;
    const auto open = line.rfind('('), pct = line.rfind("%)");
    ASSERT_NE(open, std::string::npos) << line;
    ASSERT_NE(pct, std::string::npos) << line;
    const double share = std::stod(line.substr(open + 1, pct - open - 1));
    EXPECT_GT(share, 0) << line;
    EXPECT_LE(share, 100) << line;
    smallest = std::min(smallest, share);
  }
  EXPECT_EQ(rows, 4) << r.output;
  EXPECT_EQ(fluid, 16000) << r.output;
  EXPECT_LT(smallest, 30) << r.output;
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
  // Restart under another output interval: the frames go on at that interval's times from the
  // restart's (frame k at k * 0.001 s), never back in time (the next output time was once
  // behind the restart's and the first step ran backwards).
  const auto out3 = test::scratch_dir("cli_run_interval") / "out";
  const Result r3 =
      run("run " + (test::source_dir() / "scenes/hydrostatic.toml").string() +
          " --set simulation.end_time=0.008 --set output.interval=0.001 --quiet --output " +
          out3.string() + " --restart " + (out / "frame_000001.h5").string());
  ASSERT_EQ(r3.code, 0) << r3.output;
  EXPECT_FALSE(fs::exists(out3 / "frame_000002.h5")) << "frames before the restart's time";
  for (int k = 6; k <= 8; ++k) {
    const auto f = out3 / ("frame_00000" + std::to_string(k) + ".h5");
    ASSERT_TRUE(fs::exists(f)) << f;
    EXPECT_NEAR(io::read_snapshot(MPI_COMM_SELF, f.string()).time, 0.001 * k, 1e-12);
  }
}

// render draws the chosen frames of a run as PNGs of the asked size, with something drawn on
// them, and their film (or says why there is none); bad input (a malformed --frames, a directory
// without snapshots) exits 2 with its reason and writes no picture.
// A snapshot without a field a pass needs (here the fluid's positions) is refused in one line
// that names the file and the field; no picture is written.
TEST(Cli, RenderRefusesASnapshotWithoutPositions) {
  const auto dir = test::scratch_dir("cli_render_fields");
  io::Frame f;
  f.precision = "float";
  f.phases.push_back({"fluid", {io::Field::from("density", std::vector<float>{1000, 1000}, 1)}});
  const std::string snapshot = io::SnapshotWriter(MPI_COMM_SELF, dir).write(f);
  const Result r = run("render " + dir.string() + " --no-film");
  EXPECT_NE(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("knitflow: error: " + snapshot +
                          ": render: the snapshot's fluid phase has no 3-component position field"),
            std::string::npos)
      << r.output;
  EXPECT_FALSE(fs::exists(dir / "render" / "frame_000000.png"));
}

TEST(Cli, RenderDrawsTheChosenFrames) {
  const auto out = test::scratch_dir("cli_render") / "out";
  const Result r =
      run("run " + (test::source_dir() / "scenes/hydrostatic.toml").string() +
          " --set simulation.end_time=0.01 --set output.interval=0.005 --quiet --output " +
          out.string());
  ASSERT_EQ(r.code, 0) << r.output;
  const Result d = run("render " + out.string() + " --frames 1: --width 96 --height 64");
  ASSERT_EQ(d.code, 0) << d.output;
  EXPECT_FALSE(fs::exists(out / "render/frame_000000.png"));
  for (const char* f : {"render/frame_000001.png", "render/frame_000002.png"}) {
    const io::RgbaImage img = io::read_png((out / f).string());
    EXPECT_EQ(img.width, 96);
    EXPECT_EQ(img.height, 64);
    // The background is white; the fluid's spheres are blue, darker where unlit.
    std::size_t fluid = 0;
    for (std::size_t k = 0; k < img.pixels.size(); k += 4)
      fluid += img.pixels[k + 2] > img.pixels[k] + 40;
    EXPECT_GT(fluid, 96u * 64 / 20) << f << ": too little fluid drawn";
  }
  // The film: an MP4 where ffmpeg is installed, else a message saying so (not an error).
  if (std::system("command -v ffmpeg > /dev/null 2>&1") == 0) {
    EXPECT_GT(fs::file_size(out / "render/film.mp4"), 0u) << d.output;
    EXPECT_FALSE(fs::exists(out / "render/film.ffconcat"));
  } else {
    EXPECT_NE(d.output.find("ffmpeg not found: no film"), std::string::npos) << d.output;
  }
  const Result nofilm = run("render " + out.string() + " --no-film --width 32 --height 32 --out " +
                            (out / "nofilm").string());
  ASSERT_EQ(nofilm.code, 0) << nofilm.output;
  EXPECT_TRUE(fs::exists(out / "nofilm/frame_000000.png"));
  EXPECT_FALSE(fs::exists(out / "nofilm/film.mp4"));
  const Result bad =
      run("render " + out.string() + " --frames 1:x --out " + (out / "bad").string());
  EXPECT_EQ(bad.code, 2) << bad.output;
  EXPECT_NE(bad.output.find("--frames '1:x': expected A:B:S"), std::string::npos) << bad.output;
  EXPECT_FALSE(fs::exists(out / "bad"));
  // --set over the snapshot's scene: the [render] table's size; a key it lacks is refused with
  // the scene's message, nothing written.
  const Result set = run("render " + out.string() +
                         " --no-film --frames 2:2:1 --set render.width=48 --set render.height=40 "
                         "--out " +
                         (out / "set").string());
  ASSERT_EQ(set.code, 0) << set.output;
  EXPECT_EQ(io::read_png((out / "set/frame_000002.png").string()).width, 48);
  const Result badset =
      run("render " + out.string() + " --set render.widht=48 --out " + (out / "badset").string());
  EXPECT_EQ(badset.code, 2) << badset.output;
  EXPECT_NE(badset.output.find("unknown key 'render.widht' (did you mean 'width'?)"),
            std::string::npos)
      << badset.output;
  EXPECT_FALSE(fs::exists(out / "badset"));
  const Result none = run("render " + (out / "render").string());
  EXPECT_EQ(none.code, 2) << none.output;
  EXPECT_NE(none.output.find("no snapshots (frame_NNNNNN.h5) to render"), std::string::npos)
      << none.output;
}
