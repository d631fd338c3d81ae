// The watchdog on N ranks (mpiexec -n 2): its reading is the job's (each particle once, though
// the fluid's ghosts follow the knit between steps), and a rollback goes back to the last
// checkpoint on every rank together and finishes the run.
#include "comm/MpiContext.hpp"
#include "domain/Runner.hpp"
#include "domain/Simulation.hpp"
#include "support/CouplingScenes.hpp"
#include "support/TestPaths.hpp"

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
  std::string text = test::scene_text(R"("fluid", "boundary", "knit", "contact")",
                                      "min = [-0.02, -0.02, 0.07]\nmax = [0.02, 0.02, 0.11]", -0.5);
  text.replace(text.find("gravity = [0, 0, 0]"), 19, "gravity = [0, 0, -9.81]");
  const Scene scene = parse_scene(text, "watch");
  comm::MpiContext mpi;
  auto sim = Simulation::create(scene, exec::Backend::Cpu, &mpi);
  for (int i = 0; i < 40; ++i)
    sim->step(1.0);
  const WatchReading r = sim->watch();
  const io::Frame fr = sim->frame(); // each rank's owned rows
  double mass = 0, kinetic = 0, potential = 0, vmax = 0, rho = 0;
  std::size_t rows = 0;
  for (const char* phase : {"fluid", "knit"}) {
    const io::Phase& ph = *fr.find(phase);
    const auto x = ph.find("position")->as<double>();
    const auto v = ph.find("velocity")->as<double>();
    const auto m = ph.find("mass")->as<double>();
    rows += m.size();
    for (std::size_t i = 0; i < m.size(); ++i) {
      const double v2 =
          v[3 * i] * v[3 * i] + v[3 * i + 1] * v[3 * i + 1] + v[3 * i + 2] * v[3 * i + 2];
      mass += m[i];
      kinetic += 0.5 * m[i] * v2;
      potential += m[i] * 9.81 * (x[3 * i + 2] + 0.05);
      if (phase[0] == 'f')
        vmax = std::max(vmax, std::sqrt(v2));
    }
    if (phase[0] == 'f')
      for (double d : ph.find("density")->as<double>())
        rho = std::max(rho, d);
  }
  EXPECT_GT(rows, 0u) << "a rank owns nothing: the split is not tested";
  mass = job_sum(mass);
  kinetic = job_sum(kinetic);
  potential = job_sum(potential);
  EXPECT_NEAR(r.mass, mass, 1e-12 * mass);
  EXPECT_NEAR(r.kinetic, kinetic, 1e-12 * kinetic);
  EXPECT_NEAR(r.potential, potential, 1e-12 * potential);
  EXPECT_EQ(r.fluid_max_speed, job_max(vmax));
  EXPECT_EQ(r.fluid_max_density, job_max(rho));
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
