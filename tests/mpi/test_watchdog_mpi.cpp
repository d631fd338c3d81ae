// The watchdog on N ranks (mpiexec -n 2): its reading is the job's (each particle once, though
// the fluid's ghosts follow the knit between steps), and a rollback goes back to the last
// checkpoint on every rank together and finishes the run.
#include "comm/MpiContext.hpp"
#include "domain/Runner.hpp"
#include "domain/Simulation.hpp"
#include "support/SceneFactory.hpp"
#include "support/TestPaths.hpp"
#include "support/WatchSums.hpp"

#include <gtest/gtest.h>
#include <mpi.h>

#include <algorithm>
#include <cmath>
#include <sstream>

using namespace kf;

namespace {

double job_sum(double v) {
  MPI_Allreduce(MPI_IN_PLACE, &v, 1, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
  return v;
}

double job_max(double v) {
  MPI_Allreduce(MPI_IN_PLACE, &v, 1, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
  return v;
}

} // namespace

// The coupled patch and block split over the ranks: the reading against the sums over each
// rank's owned rows of the collective frame (1e-12: the same terms in another order).
TEST(WatchReadingMpi, CountsEachParticleOnce) {
  const Scene scene = test::falling_coupled_scene();
  comm::MpiContext mpi;
  auto sim = Simulation::create(scene, exec::Backend::Cpu, &mpi);
  for (int i = 0; i < 40; ++i)
    sim->step(1.0);
  const WatchReading r = sim->watch();
  // Each rank's owned rows of the collective frame, summed over the ranks.
  const test::FrameSums f = test::frame_sums(sim->frame(), 9.81, -0.05);
  EXPECT_GT(f.rows, 0u) << "a rank owns nothing: the split is not tested";
  const double mass = job_sum(f.mass), kinetic = job_sum(f.kinetic),
               potential = job_sum(f.potential);
  EXPECT_NEAR(r.mass, mass, 1e-12 * mass);
  EXPECT_NEAR(r.kinetic, kinetic, 1e-12 * kinetic);
  EXPECT_NEAR(r.potential, potential, 1e-12 * potential);
  EXPECT_EQ(r.fluid_max_speed, job_max(f.fluid_max_speed));
  EXPECT_EQ(r.fluid_max_density, job_max(f.fluid_max_density));
}

// The piston's work on the fluid split over the ranks (each fluid particle's share added once,
// by its owner; the ghosts kept by the "verlet" lists between sorts add nothing) against the
// same run on one rank, made on every rank alike. The piston turned to push along y across the
// tank's length (x), so the ranks' border (across x) runs through the water at its face: the
// same forces, summed in another order, so to rounding (1e-9: measured 2e-16; with the ghosts
// counted too, tried, 21% more).
TEST(WatchReadingMpi, MoversWorkIsTheOneRanks) {
  Scene scene = test::piston_scene(0.01, 0.1);
  scene.domain.max = {0.2, 0.1, 0.15};
  scene.fluid.blocks[0].min = {0, 0.02, 0};
  scene.fluid.blocks[0].max = {0.2, 0.1, 0.05};
  scene.obstacles[0].min = {-0.1, -0.2, -0.1};
  scene.obstacles[0].max = {0.3, 0.02, 0.3};
  scene.obstacles[0].velocity = {0, 0.1, 0};
  scene.solver.neighbour_list = Scene::Solver::NeighbourLists::Verlet;
  comm::MpiContext mpi;
  auto split = Simulation::create(scene, exec::Backend::Cpu, &mpi);
  auto whole = Simulation::create(scene, exec::Backend::Cpu);
  while (split->time() < scene.end_time - 1e-12) {
    split->step(scene.end_time);
    whole->step(scene.end_time);
  }
  const WatchReading a = split->watch(), b = whole->watch();
  EXPECT_GT(b.work, 0.0);
  EXPECT_NEAR(a.work, b.work, 1e-9 * b.work);
  EXPECT_EQ(split->steps(), whole->steps());
  // The sums over the owned rows only (the flags on the backend): the kept ghosts counted too
  // would add their mass (the same particles, so to rounding).
  EXPECT_NEAR(a.mass, b.mass, 1e-12 * b.mass);
  EXPECT_NEAR(a.kinetic, b.kinetic, 1e-9 * b.kinetic);
}

// An instability after step 150 (KF_FAULT, found on every rank as a real one is, from the job's
// bounds): both ranks go back to the checkpoint of step 120 together, with halved steps, and
// end where the scene ends.
TEST(WatchdogMpi, RollbackOnEveryRankFinishesTheRun) {
  comm::MpiContext mpi;
  const auto dir = test::scratch_dir("watchdog_rollback_mpi");
  Scene scene = load_scene((test::source_dir() / "scenes" / "dambreak.toml").string(),
                           {"fluid.spacing=0.02", "simulation.end_time=0.2", "output.interval=0.05",
                            "output.checkpoint_steps=40", "solver.on_instability=\"rollback\""});
  scene.output.dir = (dir / "out").string();
  RunOptions opt;
  opt.progress = false;
  opt.fault = parse_fault("0:150:instability");
  std::ostringstream log;
  const RunSummary sum = run_scene(scene, opt, mpi, log);
  EXPECT_EQ(sum.rollbacks, 1u) << log.str();
  EXPECT_DOUBLE_EQ(sum.sim_time, 0.2);
  if (mpi.root()) {
    EXPECT_NE(log.str().find("rollback 1 of 3 to " + scene.output.dir +
                             "/checkpoints/checkpoint_000000000120.h5 with cfl 0.1"),
              std::string::npos)
        << log.str();
  }
}
