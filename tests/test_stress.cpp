// The stress suite (P8): every scene of scenes/stress, at CI size here (each case's overrides;
// KF_STRESS_FULL=1 runs the scenes as written, KF_STRESS_DEVICE=cuda on the GPU: jobs/stress.sh;
// KF_STRESS_SET="key=value;..." adds overrides, to try settings),
// checked every few dozen steps against what no hard case may break:
// - every value finite (the watchdog's reading: energies, speeds, densities);
// - the kinetic plus gravitational energy within the start's (its springs' and contacts' stored
//   energy included) and the work the moving solids and handles did, measured as the run goes
//   (domain/Watchdog's budget, 2% for rounding and the floor): nothing else does work,
//   dissipation only takes;
// - the fluid's density error within the case's bound;
// - no particle inside a solid (fluid and knit: signed distance to every solid, walls included,
//   not negative);
// - the fluid's particles and mass kept (counting what left through an open side);
// - the knit's layers in order through the thickness (grid pieces);
// - where the knit spans the box (its sheet splits it in two): every fluid particle on the side
//   of the sheet it started on (the sheet's faces a ray from it meets, counted by brute force,
//   independent of the solver's guard), unless the model absorbs and drips;
// - water meant to rest stays at rest (the case's speed bound after it settled).
// Each case prints what it measured, the bounds' reasons beside them.
#include "domain/KnitBuilder.hpp"
#include "domain/Scene.hpp"
#include "domain/SheetFaces.hpp"
#include "domain/Simulation.hpp"
#include "domain/Watchdog.hpp"
#include "kernels/coupling/SheetGuard_K.hpp"
#include "support/KnitChecks.hpp"
#include "support/TestPaths.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <string>
#include <vector>

using namespace kf;

namespace {

bool full_size() {
  const char* e = std::getenv("KF_STRESS_FULL");
  return e && std::string(e) == "1";
}

/// A bound at CI size and at full size (the scene as written), each near what it measured.
struct Bound {
  double ci = 0, full = 0;
  Bound(double both = 0) : ci(both), full(both) {}
  Bound(double c, double f) : ci(c), full(f) {}
  double operator()() const { return full_size() ? full : ci; }
};

struct StressCase {
  const char* name;            // scenes/stress/NAME.toml
  std::vector<std::string> ci; // overrides at CI size
  Bound density_error;         // bound on (rho - rho0) / rho0
  double rest_after = -1;      // >= 0: from this time on the fluid must rest ...
  Bound rest_speed = Bound();  // ... below this speed [m/s]
  double jitter = 0;           // start positions moved by up to jitter * spacing (seeded)
  int seeds = 1;
  bool folds = false; // the knit folds in the x-z plane: its profiles there must not cross
  bool sheet_splits_box = false;        // no fluid particle may change sides of the knit's sheet
  std::vector<std::string> always = {}; // overrides at every size (the case's own settings)
};

exec::Backend device() {
  const char* e = std::getenv("KF_STRESS_DEVICE");
  return e && std::string(e) == "cuda" ? exec::Backend::Cuda : exec::Backend::Cpu;
}

/// Moves every fluid particle by up to jitter * spacing along each axis (a seeded LCG).
void perturb(Simulation& sim, double jitter, std::uint32_t seed) {
  io::Frame fr = sim.frame();
  for (auto& ph : fr.phases) {
    if (ph.name != "fluid")
      continue;
    for (auto& f : ph.fields) {
      if (f.name != "position")
        continue;
      const double dp = sim.scene().fluid.spacing;
      std::uint32_t state = seed * 2654435761u + 12345u;
      auto next = [&] {
        state = state * 1664525u + 1013904223u;
        return state / 4294967296.0 - 0.5;
      };
      if (f.type == io::DType::F32) {
        auto x = f.as<float>();
        for (float& v : x)
          v += float(2 * jitter * dp * next());
        f = io::Field::from("position", x, 3);
      } else {
        auto x = f.as<double>();
        for (double& v : x)
          v += 2 * jitter * dp * next();
        f = io::Field::from("position", x, 3);
      }
    }
  }
  sim.restore(fr);
}

/// The most times a profile of the middle layer along the courses turns back along x (a fold
/// in the x-z plane), steps under a quarter of the rest spacing ignored.
int profile_turns(const std::vector<Vec3d>& x, const KnitPieceLayout& L) {
  int most = 0;
  for (int i = 0; i < L.nu; ++i) {
    int turns = 0, dir = 0;
    double anchor = x[L.index(1, i, 0)].x;
    const double step = 0.25 * norm(x[L.index(1, i, 1)] - x[L.index(1, i, 0)]);
    for (int j = 1; j < L.nv; ++j) {
      const double d = x[L.index(1, i, j)].x - anchor;
      if (std::abs(d) < step)
        continue;
      const int sign = d > 0 ? 1 : -1;
      turns += dir != 0 && sign != dir;
      dir = sign;
      anchor = x[L.index(1, i, j)].x;
    }
    most = std::max(most, turns);
  }
  return most;
}

struct Measured {
  double worst_energy_ratio = 0; // largest (kinetic + gravitational) / budget
  double worst_density_error = 0;
  double closest_fluid = 1e30, closest_knit = 1e30; // signed distance to a solid [m]
  double rest_speed = 0;                            // largest fluid speed while resting
  std::size_t layer_swaps = 0;
  std::size_t crossings = 0; // a fold through another (the profiles in the x-z plane)
  int turns = 0;             // the most times a middle-layer profile turns back along x
  std::int64_t lost_particles = 0;
  double lost_mass = 0;
  std::uint64_t steps = 0;
  std::uint64_t guard_corrections = 0; // fluid put back out of a solid by the boundary's guard
  std::size_t changed_sides = 0;       // fluid particles on the other side of the knit's sheet
  std::uint64_t sheet_corrections = 0; // put back by the tunnelling guard
};

/// Per fluid particle (by id), how many of the sheet's faces a ray from it meets (a fixed
/// direction off the axes: no ray runs along a face's edge of a grid piece).
std::map<std::uint64_t, int> faces_above(const io::Frame& fr, const SheetFaces& sheet) {
  auto points = [&](const char* phase) {
    const io::Field& f = *fr.find(phase)->find("position");
    return f.type == io::DType::F32 ? test::as_points(f.as<float>())
                                    : test::as_points(f.as<double>());
  };
  const auto x = points("fluid"), k = points("knit");
  const auto id = fr.find("fluid")->find("id")->as<std::uint64_t>();
  const Vec3d ray{0.0123, 0.0371, 10.0};
  std::map<std::uint64_t, int> out;
  for (std::size_t j = 0; j < x.size(); ++j) {
    int n = 0;
    for (const auto& f : sheet.faces)
      n += segment_crosses_triangle(x[j], x[j] + ray, k[f[0]], k[f[1]], k[f[2]]).crosses;
    out[id[j]] = n;
  }
  return out;
}

Measured run_case(const StressCase& c, std::uint32_t seed) {
  std::vector<std::string> over{"output.enabled=false"};
  if (!full_size())
    over.insert(over.end(), c.ci.begin(), c.ci.end());
  over.insert(over.end(), c.always.begin(), c.always.end());
  if (const char* e = std::getenv("KF_STRESS_SET")) { // more overrides, ';' between them
    std::string rest = e;
    for (std::size_t at; !rest.empty(); rest = at == std::string::npos ? "" : rest.substr(at + 1)) {
      at = rest.find(';');
      over.push_back(rest.substr(0, at));
    }
  }
  Scene scene = load_scene(
      (test::source_dir() / "scenes" / "stress" / (std::string(c.name) + ".toml")).string(), over);
  scene.solver.watchdog_energy_rise = 0.02; // the budget's margin: rounding of the sums
  auto sim = Simulation::create(scene, device());
  if (c.jitter > 0)
    perturb(*sim, c.jitter, seed);
  const Diagnostics d0 = sim->diagnostics();
  const Watchdog dog(scene, sim->watch(), stored_energy(d0), sim->time());
  KnitMesh mesh;
  if (scene.has(Module::Knit))
    mesh = build_knit(scene);
  SheetFaces sheet;
  std::map<std::uint64_t, int> start_side;
  if (c.sheet_splits_box) {
    sheet = build_sheet_faces(mesh);
    start_side = faces_above(sim->frame(), sheet);
  }
  const double rho0 = scene.fluid.rest_density;
  Measured m;
  const int every = 25, frame_every = 500;
  for (;;) {
    const bool done = sim->time() >= scene.end_time - 1e-12 ||
                      (scene.solver.max_steps > 0 &&
                       sim->steps() >= static_cast<std::uint64_t>(scene.solver.max_steps));
    if (!done)
      sim->step(scene.end_time);
    if (!done && sim->steps() % every != 0)
      continue;
    const WatchReading r = sim->watch();
    EXPECT_TRUE(std::isfinite(r.kinetic + r.potential + r.fluid_max_speed + r.knit_max_speed +
                              r.fluid_max_density))
        << c.name << ": not finite at step " << sim->steps();
    if (!std::isfinite(r.kinetic + r.potential))
      break;
    m.worst_energy_ratio =
        std::max(m.worst_energy_ratio, (r.kinetic + r.potential) / dog.energy_limit(r));
    if (scene.has(Module::Fluid))
      m.worst_density_error = std::max(m.worst_density_error, r.fluid_max_density / rho0 - 1);
    if (c.rest_after >= 0 && sim->time() >= c.rest_after)
      m.rest_speed = std::max(m.rest_speed, r.fluid_max_speed);
    const Diagnostics d = sim->diagnostics();
    if (scene.has(Module::Fluid)) {
      m.closest_fluid = std::min(m.closest_fluid, d.min_rigid_distance);
      m.guard_corrections = d.guard_corrections;
      const std::int64_t now = std::int64_t(d.fluid + d.outflow_particles + d.absorbed_particles) -
                               std::int64_t(d.emitted_particles);
      const std::int64_t start = std::int64_t(d0.fluid);
      m.lost_particles = std::max(m.lost_particles, std::abs(now - start));
      m.lost_mass = std::max(m.lost_mass, std::abs(d.fluid_mass + d.outflow_mass - d0.fluid_mass) /
                                              d0.fluid_mass);
    }
    if (scene.has(Module::Knit)) {
      m.closest_knit = std::min(m.closest_knit, d.knit_min_rigid_distance);
      if (sim->steps() % frame_every == 0 || done) {
        const io::Frame fr = sim->frame();
        const io::Field& xf = *fr.find("knit")->find("position");
        const auto x = xf.type == io::DType::F32 ? test::as_points(xf.as<float>())
                                                 : test::as_points(xf.as<double>());
        for (const auto& piece : mesh.pieces)
          if (piece.grid) {
            m.layer_swaps = std::max(m.layer_swaps, test::layer_order_violations(x, mesh.x, piece));
            if (c.sheet_splits_box) {
              std::size_t changed = 0;
              for (const auto& [id, n] : faces_above(fr, sheet))
                changed += start_side.count(id) && start_side.at(id) != n;
              m.changed_sides = std::max(m.changed_sides, changed);
            }
            if (c.folds) { // a planar fold: a draped piece's profiles cross in projection
              m.crossings =
                  std::max(m.crossings, test::profile_crossings(x, piece, {1, 0, 0}, {0, 0, 1}));
              m.turns = std::max(m.turns, profile_turns(x, piece));
            }
          }
      }
    }
    if (done)
      break;
  }
  m.steps = sim->steps();
  m.sheet_corrections = sim->diagnostics().sheet_corrections;
  std::printf(
      "%s (seed %u): %llu steps to t = %.4g s; energy at most %.4f of its budget; density "
      "error at most %.3g%%; closest to a solid: fluid %.3g m, knit %.3g m; rest speed "
      "%.3g m/s; layer swaps %zu, fold crossings %zu (turns %d); particles lost %lld, mass %.2e; "
      "guard corrections %llu; fluid changed sides of the knit %zu (sheet guard put back %llu)\n",
      c.name, seed, static_cast<unsigned long long>(m.steps), sim->time(), m.worst_energy_ratio,
      100 * m.worst_density_error, m.closest_fluid, m.closest_knit, m.rest_speed, m.layer_swaps,
      m.crossings, m.turns, static_cast<long long>(m.lost_particles), m.lost_mass,
      static_cast<unsigned long long>(m.guard_corrections), m.changed_sides,
      static_cast<unsigned long long>(m.sheet_corrections));
  return m;
}

void check(const StressCase& c) {
  // Every seed at full size; the first at CI size (CI's 40 minutes: the second Wendland tank
  // took 112 s there).
  const int seeds = full_size() ? c.seeds : 1;
  for (int seed = 1; seed <= seeds; ++seed) {
    SCOPED_TRACE(std::string(c.name) + " seed " + std::to_string(seed));
    const Measured m = run_case(c, std::uint32_t(seed));
    EXPECT_LE(m.worst_energy_ratio, 1.0) << "energy rose past what the run started with";
    EXPECT_LE(m.worst_density_error, c.density_error());
    EXPECT_GE(m.closest_fluid, 0.0) << "a fluid particle inside a solid";
    EXPECT_GE(m.closest_knit, 0.0) << "a knit point inside a solid";
    EXPECT_EQ(m.layer_swaps, 0u) << "the knit's layers swapped";
    EXPECT_EQ(m.changed_sides, 0u) << "fluid passed through the knit's sheet";
    if (c.folds) {
      EXPECT_EQ(m.crossings, 0u) << "the knit passed through itself";
      EXPECT_GE(m.turns, 1) << "the knit never folded: the case tests little";
    }
    EXPECT_EQ(m.lost_particles, 0) << "fluid particles appeared or vanished";
    EXPECT_LE(m.lost_mass, 1e-6) << "fluid mass appeared or vanished";
    if (c.rest_after >= 0) {
      EXPECT_LE(m.rest_speed, c.rest_speed()) << "the water at rest moves";
    }
  }
}

} // namespace

// Bounds: near what each case reached at CI size (2 cores) and at full size (an H200, jobs/gpu/
// p8_stress.sh), printed by each run and kept in docs/VALIDATION.md, with the reason.

// Rest: from 1.5 s on (the damping stops at 0.3 s and leaves a transient decaying over about a
// second: rms speed 0.026 m/s at 0.5 s, 0.005 at 3 s), the fastest particle at 0.0556 m/s (CI)
// and 0.0488 (full, 10 s); with summation density 2.1 m/s by 2 s. The density: 0.67% and 0.72%
// (the column's weight at c = 15 m/s).
TEST(Stress, TankAtRestStaysAtRest) {
  check({"tank_rest", {"fluid.spacing=0.01", "simulation.end_time=3.0"}, 0.01, 1.5, 0.06});
}

// 0.94% (CI) and 0.95% (full); the fastest particle after 0.8 s 0.0121 m/s (CI: to 1 s) and
// 0.027 (full: to 2 s, the ringing after the damping stops at 0.6 s); seeds agree to 5% (two at
// full size). CI's tank is 0.10 m wide, the same column (0.15 m: 0.95%, 0.0103 m/s, 115 s).
TEST(Stress, WendlandTankFromPerturbedStarts) {
  check({"wendland_tank",
         {"simulation.end_time=1.0", "domain.max=[0.1, 0.1, 0.3]",
          "fluid.block.0.max=[0.1, 0.1, 0.25]"},
         0.012,
         0.8,
         {0.015, 0.03},
         1e-3,
         2});
}

// The waves' impacts on the walls (about 1.7 m/s at c = 15: Mach 0.11) compress the fluid; the
// largest over 100,000 chaotic steps depends on rounding: 14.3% on the CPU, 17.7% on an H200.
// CI runs the first 25,000 (20 s on one core): the CPU's largest, 14.3%, and its energy, 0.949 of
// the budget, are reached within them (measured: the same at 20,000, 25,000, 30,000, 50,000 and
// 100,000 steps).
TEST(Stress, LongRunOfTwentyFiveThousandStepsAndAHundredAtFullSize) {
  check({"long_run", {"solver.max_steps=25000"}, 0.2});
}

TEST(Stress, KnitSpringsAHundredTimesStiffer) {
  check({"stiff_knit",
         {"knit.piece.0.wales=24", "knit.piece.0.courses=24", "simulation.end_time=0.2"},
         0});
}

// The fluid pushed out of the knit it was spawned in: 7.17% (CI), 10.1% (full).
TEST(Stress, FluidSpawnedOverlappingAnObstacleAndTheKnit) {
  check({"overlap", {"fluid.spacing=0.01", "simulation.end_time=0.2"}, {0.09, 0.12}});
}

// Squeezed at 0.5 m/s into the corner: 3.74% (CI), 4.17% (full).
TEST(Stress, FluidPiledIntoACornerUnderAMovingSolid) {
  check({"corner_piston", {"fluid.spacing=0.01"}, 0.05});
}

// Layers and folds: none may swap or cross (exact); the knit outside the box.
TEST(Stress, HeavySoakedPieceFoldsOverASharpEdge) {
  StressCase c{"soaked_fold", {"knit.piece.0.wales=24", "knit.piece.0.courses=24"}, 0};
  c.folds = true;
  check(c);
}

// A block fired at 10 m/s onto a patch pinned across the box (1,500 N/m, 50 kPa through the
// thickness). Without the tunnelling guard the fluid passes between the knit's points (the
// contact acts between points: its reach, 3.27 mm, is under their 5.8 mm diagonal); with it none.
// The density: 7.76% at the impact on the CPU, 7.89% on an H200 (8.52% / 10.6% before the
// guard's reaction on the knit), the water hammer's rho c v = 1 MPa giving 7.9% by the Tait
// equation (c = 100 m/s); the peak's excess over it depends on rounding (where the block's
// corners first close on the sheet).
TEST(Stress, FastJetOntoAPinnedPatch) {
  StressCase c{"jet", {}, 0.12};
  c.sheet_splits_box = true;
  check(c);
}

// The check above can fail: the same jet without the guard, to 0.02 s, has fluid on the far side.
TEST(Stress, TheJetTunnelsWithoutTheGuard) {
  StressCase c{"jet", {}, 1.0};
  c.always = {"coupling.sheet_guard=\"off\"", "simulation.end_time=0.02"};
  c.sheet_splits_box = true;
  const Measured m = run_case(c, 1);
  EXPECT_GT(m.changed_sides, 100u) << "the jet no longer tests the guard";
  EXPECT_EQ(m.sheet_corrections, 0u);
}
