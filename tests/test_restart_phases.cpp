// Restart for every phase (P11 item 3): a run restarted from a snapshot written mid-run ends bit
// for bit where the uninterrupted run ends, every field's bytes equal, for the drape (knit alone),
// the pour (fluid, walls and knit coupled by the paper's capillary model), the wicking (the
// mass-conserving model, restarted while the knit absorbs) and the dam break (fluid alone); each
// with the fluid's cell walk (neighbour_list "off") and with "verlet" lists, in float and double,
// on the CPU and on the GPU (skipped without one).
//
// What a restart needs beyond the particles: the grids kept over steps (the fluid's with its
// "verlet" lists, the knit's self-collision grid, the coupling's knit grid) must be those of the
// uninterrupted run, sorted for the same positions and sorted again at the same steps, since a
// sort at another step sums the same pairs in another order (SimulationT::restore_fluid_grid).
#include "domain/Simulation.hpp"
#include "io/SnapshotReader.hpp"
#include "io/SnapshotWriter.hpp"
#include "support/FrameChecks.hpp"
#include "support/TestPaths.hpp"

#include <gtest/gtest.h>
#include <mpi.h>

#include <cstdio>
#include <functional>
#include <ostream>
#include <string>
#include <vector>

using namespace kf;
using test::expect_frames_equal;

namespace {

using Lists = Scene::Solver::NeighbourLists;

/// One scene, coarsened to a few seconds on one core, and what must be going on at its snapshot
/// for the restart to test anything (checked on the uninterrupted run).
struct Case {
  std::string name;                   // in the test's name
  std::string file;                   // under scenes/
  std::vector<std::string> overrides; // coarsening
  bool fluid;                         // "verlet" lists are the fluid's: no variant without it
  int steps;                          // of the uninterrupted run
  int snapshot_after;                 // steps before the snapshot
  std::function<void(const Diagnostics& at_snapshot, const Diagnostics& at_end)> expect;
};

struct Param {
  Case scene;
  Lists lists;
  Precision precision;
  exec::Backend backend;
};

std::string param_name(const Param& p) {
  return p.scene.name + (p.lists == Lists::Verlet ? "_Verlet" : "_Walk") +
         (p.precision == Precision::Float ? "_Float" : "_Double") +
         (p.backend == exec::Backend::Cuda ? "_Gpu" : "_Cpu");
}

// gtest prints a failing parameter with this (not as raw bytes).
void PrintTo(const Param& p, std::ostream* os) {
  *os << param_name(p);
}

class RestartPhases : public ::testing::TestWithParam<Param> {};

} // namespace

TEST_P(RestartPhases, ContinuesBitForBit) {
  const Param& p = GetParam();
  if (p.backend == exec::Backend::Cuda && !exec::cuda_available())
    GTEST_SKIP() << "no CUDA device";
  Scene s = load_scene((test::source_dir() / "scenes" / p.scene.file).string(), p.scene.overrides);
  s.solver.neighbour_list = p.lists;
  s.precision = p.precision;
  const auto dir = test::scratch_dir("restart_phases_" + param_name(p));

  // Uninterrupted, with a snapshot after snapshot_after steps.
  auto full = Simulation::create(s, p.backend);
  io::SnapshotWriter writer(MPI_COMM_WORLD, dir.string());
  std::string snap;
  Diagnostics at_snapshot;
  double t_snapshot = 0;
  for (int k = 1; k <= p.scene.steps; ++k) {
    full->step(1e9);
    if (k == p.scene.snapshot_after) {
      at_snapshot = full->diagnostics();
      t_snapshot = full->time();
      io::Frame fr = full->frame();
      fr.index = 1;
      snap = writer.write(fr);
      // The written file holds exactly the state.
      expect_frames_equal(io::read_snapshot(MPI_COMM_WORLD, snap), fr);
    }
  }
  const Diagnostics at_end = full->diagnostics();
  std::printf("%s: %zu fluid, %zu knit points; snapshot at step %d (t = %.5f s) of %d; at it "
              "%llu fluid-knit contacts, max saturation %.3g, absorbed %.3g kg; fluid sorts %llu\n",
              param_name(p).c_str(), at_end.fluid, at_end.knit, p.scene.snapshot_after, t_snapshot,
              p.scene.steps, static_cast<unsigned long long>(at_snapshot.coupling_contacts),
              at_snapshot.max_saturation, at_snapshot.absorbed_mass,
              static_cast<unsigned long long>(at_end.fluid_sorts));
  p.scene.expect(at_snapshot, at_end);

  // Restarted from the snapshot, to the same step.
  auto resumed = Simulation::create(s, p.backend);
  resumed->restore(io::read_snapshot(MPI_COMM_WORLD, snap));
  EXPECT_EQ(resumed->steps(), static_cast<std::uint64_t>(p.scene.snapshot_after));
  for (int k = p.scene.snapshot_after; k < p.scene.steps; ++k)
    resumed->step(1e9);
  expect_frames_equal(full->frame(), resumed->frame());
}

namespace {

std::vector<Case> cases() {
  return {
      // 24 x 24 stitches (1,875 points) dropped onto the sphere: the self-collision grid is
      // sorted 4 times before the snapshot and 4 times after it.
      {"Drape",
       "drape.toml",
       {"output.enabled=false", "knit.piece.0.wales=24", "knit.piece.0.courses=24",
        "knit.piece.0.center=[0, 0, 0.505]", "knit.piece.0.velocity=[0, 0, -0.5]"},
       false,
       1000,
       500,
       [](const Diagnostics& snap, const Diagnostics&) {
         EXPECT_GT(snap.knit_kinetic_energy, 0.0);
       }},
      // The paper's capillary model (scenes/pour.toml): an 8 x 8 x 10 column at dp = 1 cm lands
      // on 32 x 32 stitches (3,267 points; fewer would make the contact reach exceed the
      // support, which "verlet" lists refuse). It first pushes the knit away; at the snapshot it
      // is back, in contact and wetting it.
      {"Pour",
       "pour.toml",
       {"output.enabled=false", "fluid.spacing=0.01", "knit.piece.0.wales=32",
        "knit.piece.0.courses=32", "fluid.block.0.min=[-0.04, -0.04, 0.53]",
        "fluid.block.0.max=[0.04, 0.04, 0.63]"},
       true,
       250,
       150,
       [](const Diagnostics& snap, const Diagnostics&) {
         EXPECT_GT(snap.coupling_contacts, 0u);
         EXPECT_GT(snap.max_saturation, 0.0);
       }},
      // The conserving model (scenes/wicking.toml): the strip (8 x 32 stitches) starts with its
      // foot at the pool's surface, so that it has soaked up fluid by the snapshot; absorption
      // and wicking go on after it.
      {"Wicking",
       "wicking.toml",
       {"output.enabled=false", "knit.piece.0.courses=32", "knit.piece.0.center=[0, 0, 0.111]",
        "knit.pin.0.min=[-0.02, -0.01, 0.186]", "knit.pin.0.max=[0.02, 0.01, 0.196]",
        "knit.pin.1.min=[-0.02, -0.01, 0.026]", "knit.pin.1.max=[0.02, 0.01, 0.036]"},
       true,
       200,
       100,
       [](const Diagnostics& snap, const Diagnostics& end) {
         EXPECT_GT(snap.absorbed_mass, 0.0);
         EXPECT_GT(end.absorbed_mass, snap.absorbed_mass); // absorbs on
         EXPECT_LT(end.fluid_mass, snap.fluid_mass);
         EXPECT_GT(end.diffused_mass, snap.diffused_mass); // wicks on
       }},
      // The fluid alone (scenes/dambreak.toml at dp = 2 cm): without a coupling the "verlet"
      // lists are kept on the host's bounds on the motion, which the snapshot carries too.
      {"DamBreak",
       "dambreak.toml",
       {"output.enabled=false", "fluid.spacing=0.02"},
       true,
       300,
       150,
       [](const Diagnostics& snap, const Diagnostics&) { EXPECT_GT(snap.kinetic_energy, 0.0); }},
  };
}

std::vector<Param> params() {
  std::vector<Param> out;
  for (exec::Backend b : {exec::Backend::Cpu, exec::Backend::Cuda})
    for (const Case& c : cases())
      for (Lists l : {Lists::Off, Lists::Verlet})
        if (c.fluid || l == Lists::Off)
          for (Precision prec : {Precision::Float, Precision::Double})
            out.push_back({c, l, prec, b});
  return out;
}

} // namespace

INSTANTIATE_TEST_SUITE_P(Scenes, RestartPhases, ::testing::ValuesIn(params()),
                         [](const ::testing::TestParamInfo<Param>& info) {
                           return param_name(info.param);
                         });
