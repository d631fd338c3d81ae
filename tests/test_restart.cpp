// Snapshots through the whole simulation: a run restarted from a snapshot ends bit for bit where
// the uninterrupted run ends, and the written state round-trips exactly.
#include "core/Error.hpp"
#include "domain/Simulation.hpp"
#include "io/SnapshotReader.hpp"
#include "io/SnapshotWriter.hpp"
#include "support/FrameChecks.hpp"
#include "support/SceneFactory.hpp"
#include "support/TestPaths.hpp"

#include <gtest/gtest.h>
#include <mpi.h>

using namespace kf;
using test::expect_frames_equal;

namespace {

Scene small_scene(Precision prec) {
  Scene s = test::tank_scene({0.2, 0.1, 0.2}, {0.08, 0.1, 0.12}, 0.01);
  s.solver.kernel = KernelType::CubicSpline;
  s.precision = prec;
  s.obstacles.push_back({}); // a moving sphere, so moving boundaries are restarted too
  s.obstacles.back().shape = ObstacleShape::Sphere;
  s.obstacles.back().center = {0.15, 0.05, 0.05};
  s.obstacles.back().radius = 0.03;
  s.obstacles.back().velocity = {-0.1, 0, 0};
  s.text = "# test scene";
  return s;
}

class Restart : public ::testing::TestWithParam<Precision> {};

} // namespace

namespace {

void expect_restart_continues(const Scene& s, const std::string& name) {
  const auto dir = test::scratch_dir("restart_" + name);
  // Uninterrupted: 60 steps, with a snapshot after step 25.
  auto full = Simulation::create(s, exec::Backend::Cpu);
  io::SnapshotWriter writer(MPI_COMM_WORLD, dir.string());
  std::string snap;
  for (int k = 0; k < 60; ++k) {
    full->step(1e9);
    if (k == 24) {
      io::Frame fr = full->frame();
      fr.index = 1;
      snap = writer.write(fr);
      // The written file holds exactly the state.
      expect_frames_equal(io::read_snapshot(MPI_COMM_WORLD, snap), fr);
    }
  }
  // Restarted from the snapshot: 35 more steps.
  auto resumed = Simulation::create(s, exec::Backend::Cpu);
  resumed->restore(io::read_snapshot(MPI_COMM_WORLD, snap));
  EXPECT_EQ(resumed->steps(), 25u);
  for (int k = 25; k < 60; ++k)
    resumed->step(1e9);
  expect_frames_equal(full->frame(), resumed->frame());
}

} // namespace

TEST_P(Restart, ContinuesBitForBit) {
  expect_restart_continues(small_scene(GetParam()), std::string(to_string(GetParam())));
}

// Under the continuity equation the density and its last two rates are state: the snapshot
// carries them (density_rate, density_rate_previous).
TEST(Restart, ContinuityContinuesBitForBit) {
  Scene s = small_scene(Precision::Float);
  s.solver.density = DensityModel::Continuity;
  expect_restart_continues(s, "continuity");
}

TEST(Restart, ContinuityRefusesASummationSnapshot) {
  Scene s = small_scene(Precision::Float);
  auto a = Simulation::create(s, exec::Backend::Cpu);
  s.solver.density = DensityModel::Continuity;
  auto b = Simulation::create(s, exec::Backend::Cpu);
  try {
    b->restore(a->frame());
    FAIL() << "a summation snapshot restarted a continuity run";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("density_rate"), std::string::npos) << e.what();
  }
}

INSTANTIATE_TEST_SUITE_P(Precisions, Restart,
                         ::testing::Values(Precision::Float, Precision::Double));

TEST(Restart, RefusesAnotherPrecision) {
  const auto dir = test::scratch_dir("restart_precision");
  auto a = Simulation::create(small_scene(Precision::Float), exec::Backend::Cpu);
  io::Frame fr = a->frame();
  auto b = Simulation::create(small_scene(Precision::Double), exec::Backend::Cpu);
  EXPECT_THROW(b->restore(fr), Error);
}
