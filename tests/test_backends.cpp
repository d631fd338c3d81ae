// The CPU and CUDA backends run the same scenes from one source, so they must agree: the dam
// break, the drape and the pour (coarsened, 120-400 steps), each in float and in double, are run
// on both and compared particle by particle, matched by id (the fluid is re-sorted by cell, so
// rows differ), plus every step's dt, the time reached and the diagnostics.
//
// They agree only to rounding, not bit for bit: nvcc contracts a*b+c into FMAs (g++ does not on
// plain x86-64), CUDA's powf (Tait EOS) rounds differently from glibc's, and device reductions
// sum in another order. Gathers visit neighbours in the same order (both sorts are stable radix
// sorts). SPH and contact are chaotic, so those ulp-level differences grow with every step; the
// bounds (see "How the bounds were set" below) come from that growth measured on the CPU.
//
// KF_COMPARE_CPU_ONLY (environment), for checking the harness without a GPU; the second side
// then runs on the CPU backend too:
//   =1      with another OpenMP thread count (half, or 2 when one thread is set). Per-particle
//           gathers do not depend on it, so both sides agree far inside the bounds (measured:
//           bit for bit).
//   =noise  with one ulp of noise in every position and velocity after every step: prints the
//           growth of rounding-sized differences the bounds are derived from.
// Without it, every comparison is skipped when this binary has no CUDA backend or sees no GPU.
// The CPU side uses OMP_NUM_THREADS threads (ctest sets 1: about 7 s for all six cases on one
// core, plus the GPU side).
//
// A second test checks that an allocation larger than the GPU fails with a kf::Error naming the
// buffer and the size, and that the device stays usable afterwards.
#include "core/Error.hpp"
#include "domain/Scene.hpp"
#include "domain/Simulation.hpp"
#include "io/Frame.hpp"
#include "kernels/exec/Backend.hpp"
#include "kernels/exec/DeviceBuffer.hpp"
#include "support/TestPaths.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <random>
#include <string>
#include <unordered_map>
#include <vector>

#if defined(_OPENMP)
#include <omp.h>
#endif

using namespace kf;

namespace {

// ---- modes and skipping -------------------------------------------------------------------------

enum class Mode { Gpu, CpuThreads, CpuNoise };

Mode mode() {
  const char* v = std::getenv("KF_COMPARE_CPU_ONLY");
  if (v == nullptr || *v == '\0' || std::strcmp(v, "0") == 0)
    return Mode::Gpu;
  return std::strcmp(v, "noise") == 0 ? Mode::CpuNoise : Mode::CpuThreads;
}

// Empty when the comparison can run.
std::string skip_reason() {
  if (mode() != Mode::Gpu)
    return {};
  if (!exec::cuda_compiled())
    return "no CUDA device: CPU/GPU comparison skipped (this binary was built without CUDA)";
  if (!exec::cuda_available())
    return "no CUDA device: CPU/GPU comparison skipped (no GPU visible)";
  return {};
}

int max_threads() {
#if defined(_OPENMP)
  return omp_get_max_threads();
#else
  return 1;
#endif
}

// Sets the OpenMP thread count for one scope (the CPU backend reads omp_get_max_threads).
class Threads {
public:
  explicit Threads(int n) : saved_(max_threads()) { set(n); }
  ~Threads() { set(saved_); }
  Threads(const Threads&) = delete;
  Threads& operator=(const Threads&) = delete;

private:
  static void set([[maybe_unused]] int n) {
#if defined(_OPENMP)
    omp_set_num_threads(n);
#endif
  }
  int saved_;
};

// ---- running a scene ----------------------------------------------------------------------------

// Moves every position and velocity component of the fluid and the knit one ulp up or down
// (pseudo-random, reproducible): more than the difference one GPU step leaves behind.
template <typename T>
void nudge_field(io::Field& f, std::mt19937_64& rng) {
  std::vector<T> v = f.as<T>();
  const T inf = std::numeric_limits<T>::infinity();
  for (T& q : v)
    q = std::nextafter(q, (rng() & 1) ? inf : -inf);
  std::memcpy(f.bytes.data(), v.data(), v.size() * sizeof(T));
}

void nudge(io::Frame& fr, std::mt19937_64& rng) {
  for (io::Phase& p : fr.phases) {
    if (p.name != "fluid" && p.name != "knit")
      continue;
    for (io::Field& f : p.fields) {
      if (f.name != "position" && f.name != "velocity")
        continue;
      if (f.type == io::DType::F32)
        nudge_field<float>(f, rng);
      else
        nudge_field<double>(f, rng);
    }
  }
}

struct RunResult {
  io::Frame frame;
  Diagnostics diag;
  std::vector<double> dt; // every step's dt
  double time = 0;
  std::uint64_t steps = 0;
  double seconds = 0; // wall time: create + steps
};

// noisy: after every step, nudge the state by one ulp (KF_COMPARE_CPU_ONLY=noise).
RunResult run(const Scene& s, exec::Backend b, int threads, int steps, bool noisy = false) {
  const Threads scope(threads);
  const auto t0 = std::chrono::steady_clock::now();
  auto sim = Simulation::create(s, b);
  RunResult r;
  r.dt.reserve(static_cast<std::size_t>(steps));
  std::mt19937_64 rng(20240611);
  for (int k = 0; k < steps; ++k) {
    r.dt.push_back(sim->step(s.end_time));
    if (noisy) {
      io::Frame fr = sim->frame();
      nudge(fr, rng);
      sim->restore(fr);
    }
  }
  r.time = sim->time();
  r.steps = sim->steps();
  r.frame = sim->frame(); // copies back from the device, so the timing includes the last kernels
  r.diag = sim->diagnostics();
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

// ---- comparing frames ---------------------------------------------------------------------------

// A field's values as doubles, whatever the scene's precision.
std::vector<double> values(const io::Phase& p, const char* name) {
  const io::Field* f = p.find(name);
  if (f == nullptr)
    throw Error(std::string("test: phase '") + p.name + "' has no field '" + name + "'");
  if (f->type == io::DType::F32) {
    const auto v = f->as<float>();
    return {v.begin(), v.end()};
  }
  return f->as<double>();
}

// For each row of `a`, the row of `b` with the same id. Both id sets must be the same set of
// unique ids; a row left at the poison value (SIZE_MAX) fails the test.
std::vector<std::size_t> match_ids(const io::Phase& a, const io::Phase& b) {
  const auto ia = a.find("id")->as<std::uint64_t>();
  const auto ib = b.find("id")->as<std::uint64_t>();
  EXPECT_EQ(ia.size(), ib.size()) << a.name << ": particle counts differ";
  std::unordered_map<std::uint64_t, std::size_t> row;
  row.reserve(ib.size());
  for (std::size_t j = 0; j < ib.size(); ++j)
    EXPECT_TRUE(row.emplace(ib[j], j).second) << a.name << ": id " << ib[j] << " twice (GPU side)";
  std::vector<std::size_t> match(ia.size(), std::numeric_limits<std::size_t>::max());
  std::unordered_map<std::uint64_t, int> seen;
  std::size_t missing = 0;
  for (std::size_t i = 0; i < ia.size(); ++i) {
    EXPECT_EQ(++seen[ia[i]], 1) << a.name << ": id " << ia[i] << " twice (CPU side)";
    const auto it = row.find(ia[i]);
    if (it != row.end())
      match[i] = it->second;
    else if (++missing <= 5)
      ADD_FAILURE() << a.name << ": id " << ia[i] << " only on the CPU side";
  }
  EXPECT_EQ(missing, 0u) << a.name << ": ids without a match";
  return match;
}

// Largest difference of a field over matched rows: the Euclidean norm of the difference for
// vectors. `nonfinite` counts rows where either side is not finite (std::max would hide a NaN).
struct FieldDiff {
  double max = 0;
  std::uint64_t worst_id = 0;
  std::size_t nonfinite = 0;
};

FieldDiff compare_field(const io::Phase& a, const io::Phase& b, const char* name,
                        const std::vector<std::size_t>& match) {
  const io::Field* fa = a.find(name);
  const int c = fa->components;
  const auto va = values(a, name), vb = values(b, name);
  const auto ids = a.find("id")->as<std::uint64_t>();
  FieldDiff d;
  for (std::size_t i = 0; i < match.size(); ++i) {
    const std::size_t j = match[i];
    if (j == std::numeric_limits<std::size_t>::max())
      continue; // already reported
    double s = 0;
    bool finite = true;
    for (int k = 0; k < c; ++k) {
      const double x = va[i * c + k], y = vb[j * c + k];
      finite = finite && std::isfinite(x) && std::isfinite(y);
      s += (x - y) * (x - y);
    }
    if (!finite) {
      ++d.nonfinite;
      continue;
    }
    if (std::sqrt(s) > d.max) {
      d.max = std::sqrt(s);
      d.worst_id = ids[i];
    }
  }
  return d;
}

// Largest |row| of a vector field (the velocity scale of a phase).
double max_norm(const io::Phase& p, const char* name) {
  const auto v = values(p, name);
  double m = 0;
  for (std::size_t i = 0; i + 2 < v.size(); i += 3)
    m = std::max(m, std::sqrt(v[i] * v[i] + v[i + 1] * v[i + 1] + v[i + 2] * v[i + 2]));
  return m;
}

double rel(double a, double b, double scale) {
  return std::abs(a - b) / std::max(scale, std::numeric_limits<double>::min());
}

// Prints a figure and records it in the XML report.
void report(const std::string& key, double value) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3e", value);
  ::testing::Test::RecordProperty(key, buf);
}

// ---- the cases ----------------------------------------------------------------------------------

// Largest differences allowed after the case's steps, each relative to the scale named.
struct Bounds {
  double position;   // / dp (fluid), / the knit's contact radius (knit)
  double velocity;   // / the CPU run's largest speed of the phase
  double density;    // / rho0
  double saturation; // absolute (s = rho~ / (phi rho0) is O(1))
  double dt;         // relative, every step's dt and the time reached
  double energy;     // relative: kinetic energies; knit elastic and potential / the knit's total
  double mass;       // relative: total fluid mass
};

// How the bounds were set. KF_COMPARE_CPU_ONLY=noise runs the second side with one ulp of noise
// in every position and velocity after every step, which is more than a GPU step leaves (most of
// its updates round exactly as the CPU's) but grows the same way. Measured over three seeds
// (figures in the cases below); a single 1-ulp nudge at the first step gave 3-10x less, so the
// growth, not the amount injected, dominates. Float bounds: 10x the largest of those, rounded
// up. Double bounds: the float bounds x 1e-7. The same noise in double gave 2-5e8 times less
// (the ratio of the two epsilons is 5.4e8), so that is still a margin of over 500 while 7 orders
// tighter. Fluid mass is summed on the host in double from identical per-particle masses, so it
// agrees exactly in any order: 1e-12 in both.
Bounds float_bounds(double position, double velocity, double density, double saturation, double dt,
                    double energy) {
  return {position, velocity, density, saturation, dt, energy, 1e-12};
}

Bounds double_bounds(const Bounds& f) {
  const double k = 1e-7;
  Bounds d = f;
  for (double* b : {&d.position, &d.velocity, &d.density, &d.saturation, &d.dt, &d.energy})
    *b *= k;
  return d; // mass: exact in both
}

struct Case {
  std::string name;
  const char* file;
  std::vector<std::string> overrides;
  int steps;
  Bounds bounds;
};

std::ostream& operator<<(std::ostream& os, const Case& c) {
  return os << c.name;
}

// Each scene in float and in double ("simulation.precision" appended to its overrides).
void add(std::vector<Case>& cases, const char* name, const char* file,
         std::vector<std::string> overrides, int steps, const Bounds& single) {
  cases.push_back({std::string(name) + "Float", file, overrides, steps, single});
  overrides.push_back("simulation.precision=\"double\"");
  cases.push_back(
      {std::string(name) + "Double", file, std::move(overrides), steps, double_bounds(single)});
}

std::vector<Case> cases() {
  std::vector<Case> c;
  // Dam break at dp = 2 cm (10 x 10 x 20 = 2,000 particles in the 0.8 x 0.2 x 0.6 m tank), 200
  // steps (t = 0.053 s): the column slumps, the front starts along the floor. Noise measured:
  // position 6.8e-4 dp, velocity 7.6e-3 of the top speed, density 7.0e-4 rho0, dt 1.1e-5, kinetic
  // energy 1.5e-5 (double: 1.4e-12 dp, 1.3e-11, 1.5e-12 rho0, 1.5e-14, 7e-15). Growth is
  // exponential: at 400 steps the float figures are 30x larger.
  add(c, "DamBreak", "dambreak.toml", {"output.enabled=false", "fluid.spacing=0.02"}, 200,
      float_bounds(1e-2, 0.1, 1e-2, 0, 2e-4, 2e-4));
  // The same with "verlet" neighbour lists (SphLists): kept over steps, built on the device.
  add(c, "DamBreakVerlet", "dambreak.toml",
      {"output.enabled=false", "fluid.spacing=0.02", "solver.neighbour_list=\"verlet\""}, 200,
      float_bounds(1e-2, 0.1, 1e-2, 0, 2e-4, 2e-4));
  // The same with the continuity equation (solver.density): one fused pass for the density rate
  // and the forces, the density carried through the list's sorts.
  add(c, "DamBreakContinuity", "dambreak.toml",
      {"output.enabled=false", "fluid.spacing=0.02", "solver.neighbour_list=\"verlet\"",
       "solver.density=\"continuity\""},
      200, float_bounds(1e-2, 0.1, 1e-2, 0, 2e-4, 2e-4));
  // The same with Monaghan's artificial viscosity (fluid.artificial_viscosity), lists off. Noise
  // measured: position 1.0e-3 dp, velocity 5.0e-3 of the top speed.
  add(c, "DamBreakArtificial", "dambreak.toml",
      {"output.enabled=false", "fluid.spacing=0.02", "fluid.artificial_viscosity=0.01"}, 200,
      float_bounds(1e-2, 0.1, 1e-2, 0, 2e-4, 2e-4));
  // The same with particle shifting (solver.shifting): the shifts' pass and their move. Noise
  // measured: position 3.0e-4 dp, velocity 2.4e-3 of the top speed.
  add(c, "DamBreakShifting", "dambreak.toml",
      {"output.enabled=false", "fluid.spacing=0.02", "solver.neighbour_list=\"verlet\"",
       "solver.shifting=\"fickian\""},
      200, float_bounds(1e-2, 0.1, 1e-2, 0, 2e-4, 2e-4));
  // Drape with 32 x 32 stitches (3,267 points), started 5 mm above the sphere at 0.5 m/s so that
  // it lands within the 400 steps (t = 0.013 s): contact with friction against the sphere.
  // Noise measured: position 2.2e-3 contact radii, velocity 1.2e-2 of the top speed, kinetic
  // energy 5.4e-6 (double: 4.2e-12, 2.5e-11, 3.6e-14).
  add(c, "Drape", "drape.toml",
      {"output.enabled=false", "knit.piece.0.wales=32", "knit.piece.0.courses=32",
       "knit.piece.0.center=[0, 0, 0.505]", "knit.piece.0.velocity=[0, 0, -0.5]"},
      400, float_bounds(5e-2, 0.2, 0, 0, 2e-4, 1e-4));
  // Pour at dp = 1 cm (an 8 x 8 x 20 column, 1,280 particles) lowered to 1.5 cm above a 32 x 32
  // stitch knit (3,267 points), 120 steps (t = 0.015 s): the column lands, pushes the knit onto
  // the sphere (DEM contact, knit-solid contact) and wets it (capillary, saturation up to 0.012).
  // Not longer: from about step 150 the knit under the jet takes contact decisions that a 1e-16
  // perturbation flips (in double too), after which the runs part by 0.5 contact radii. Noise
  // measured: fluid position 5.9e-4 dp, velocity 2.5e-3, density 7.5e-4 rho0; knit position
  // 1.0e-3 contact radii, velocity 2.0e-3; saturation 1.2e-5; knit kinetic energy 4.1e-5
  // (double: at most 3.8e-12, 3.9e-12, 1.6e-12 rho0, 3.9e-14, 6.2e-14).
  add(c, "Pour", "pour.toml",
      {"output.enabled=false", "fluid.spacing=0.01", "knit.piece.0.wales=32",
       "knit.piece.0.courses=32", "fluid.block.0.min=[-0.04, -0.04, 0.53]",
       "fluid.block.0.max=[0.04, 0.04, 0.73]"},
      120, float_bounds(2e-2, 5e-2, 1e-2, 2e-4, 2e-4, 5e-4));
  return c;
}

class Backends : public ::testing::TestWithParam<Case> {};

} // namespace

TEST_P(Backends, AgreePerParticleAfterTheSameSteps) {
  if (const std::string why = skip_reason(); !why.empty())
    GTEST_SKIP() << why;
  const Case& c = GetParam();
  const Scene s = load_scene((test::source_dir() / "scenes" / c.file).string(), c.overrides);
  const Bounds& tol = c.bounds;

  // The second side: the GPU, or the CPU in one of the self-check modes.
  const Mode m = mode();
  const int threads = max_threads();
  const int threads_other = m == Mode::CpuThreads ? (threads > 1 ? threads / 2 : 2) : threads;
  const exec::Backend other = m == Mode::Gpu ? exec::Backend::Cuda : exec::Backend::Cpu;
  const std::string other_name = m == Mode::Gpu ? exec::describe(exec::Backend::Cuda)
                                 : m == Mode::CpuThreads
                                     ? "CPU, " + std::to_string(threads_other) + " OpenMP threads"
                                     : "CPU with 1-ulp noise";

  const RunResult a = run(s, exec::Backend::Cpu, threads, c.steps);
  const RunResult b = run(s, other, threads_other, c.steps, m == Mode::CpuNoise);
  std::printf("%s: CPU (%d OpenMP threads) %.2f s, %s %.2f s; %d steps to t = %.6f s\n",
              c.name.c_str(), threads, a.seconds, other_name.c_str(), b.seconds, c.steps, a.time);
  report("cpu_seconds", a.seconds);
  report("other_seconds", b.seconds);

  // Time and steps: both sides take the same adaptive dt sequence, to rounding.
  EXPECT_EQ(a.steps, static_cast<std::uint64_t>(c.steps));
  EXPECT_EQ(a.steps, b.steps);
  double dt_worst = 0;
  std::size_t dt_step = 0;
  for (std::size_t k = 0; k < a.dt.size() && k < b.dt.size(); ++k)
    if (const double r = rel(a.dt[k], b.dt[k], a.dt[k]); !(r <= dt_worst)) {
      dt_worst = r;
      dt_step = k + 1;
    }
  const double time_rel = rel(a.time, b.time, a.time);
  std::printf("  dt: largest relative difference %.3e (step %zu); time %.3e\n", dt_worst, dt_step,
              time_rel);
  report("dt_rel", dt_worst);
  report("time_rel", time_rel);
  EXPECT_LE(dt_worst, tol.dt) << "step " << dt_step;
  EXPECT_LE(time_rel, tol.dt);

  // Diagnostics.
  const Diagnostics& da = a.diag;
  const Diagnostics& db = b.diag;
  EXPECT_EQ(da.fluid, db.fluid);
  EXPECT_EQ(da.boundary, db.boundary);
  EXPECT_EQ(da.knit, db.knit);
  const double ke_rel = rel(da.kinetic_energy, db.kinetic_energy, da.kinetic_energy);
  const double mass_rel = rel(da.fluid_mass, db.fluid_mass, da.fluid_mass);
  const double knit_e = std::abs(da.knit_kinetic_energy) + std::abs(da.knit_elastic_energy) +
                        std::abs(da.knit_potential_energy) + std::abs(da.knit_self_energy);
  const double knit_ke_rel =
      rel(da.knit_kinetic_energy, db.knit_kinetic_energy, da.knit_kinetic_energy);
  const double knit_el_rel = rel(da.knit_elastic_energy, db.knit_elastic_energy, knit_e);
  const double knit_pe_rel = rel(da.knit_potential_energy, db.knit_potential_energy, knit_e);
  std::printf("  diagnostics: fluid %zu/%zu, boundary %zu/%zu, knit %zu/%zu; relative "
              "differences: fluid kinetic energy %.3e, fluid mass %.3e, knit kinetic %.3e, "
              "elastic %.3e, potential %.3e (of the knit's energy)\n",
              da.fluid, db.fluid, da.boundary, db.boundary, da.knit, db.knit, ke_rel, mass_rel,
              knit_ke_rel, knit_el_rel, knit_pe_rel);
  std::printf("  counts (CPU/other): guard corrections %llu/%llu, knit-solid contacts %llu/%llu, "
              "self contacts %llu/%llu, fluid-knit contacts %llu/%llu, wet points %llu/%llu\n",
              static_cast<unsigned long long>(da.guard_corrections),
              static_cast<unsigned long long>(db.guard_corrections),
              static_cast<unsigned long long>(da.knit_contacts),
              static_cast<unsigned long long>(db.knit_contacts),
              static_cast<unsigned long long>(da.knit_self_contacts),
              static_cast<unsigned long long>(db.knit_self_contacts),
              static_cast<unsigned long long>(da.coupling_contacts),
              static_cast<unsigned long long>(db.coupling_contacts),
              static_cast<unsigned long long>(da.wet_points),
              static_cast<unsigned long long>(db.wet_points));
  report("kinetic_energy_rel", ke_rel);
  report("fluid_mass_rel", mass_rel);
  report("knit_kinetic_energy_rel", knit_ke_rel);
  EXPECT_LE(ke_rel, tol.energy);
  EXPECT_LE(mass_rel, tol.mass);
  EXPECT_LE(knit_ke_rel, tol.energy);
  EXPECT_LE(knit_el_rel, tol.energy);
  EXPECT_LE(knit_pe_rel, tol.energy);
  // Counts of pairs or points past a threshold: a pair within rounding of the threshold may
  // count on one side only, so they need not be equal; a handful (or 2%) apart is allowed.
  auto expect_near = [](const char* what, std::uint64_t x, std::uint64_t y) {
    const double diff = std::abs(double(x) - double(y));
    EXPECT_LE(diff, 5 + 0.02 * double(std::max(x, y))) << what << ": " << x << " vs " << y;
  };
  expect_near("guard corrections", da.guard_corrections, db.guard_corrections);
  expect_near("knit-solid contacts", da.knit_contacts, db.knit_contacts);
  expect_near("knit self contacts", da.knit_self_contacts, db.knit_self_contacts);
  expect_near("fluid-knit contacts", da.coupling_contacts, db.coupling_contacts);
  expect_near("wet knit points", da.wet_points, db.wet_points);

  // Per particle, matched by id.
  int phases = 0;
  for (const char* phase : {"fluid", "knit"}) {
    const io::Phase* pa = a.frame.find(phase);
    const io::Phase* pb = b.frame.find(phase);
    ASSERT_EQ(pa == nullptr, pb == nullptr) << phase << " on one side only";
    if (pa == nullptr)
      continue;
    ++phases;
    const bool fluid = std::strcmp(phase, "fluid") == 0;
    const std::vector<std::size_t> match = match_ids(*pa, *pb);
    const double length = fluid ? s.fluid.spacing : s.knit.radius();
    const double speed = std::max(max_norm(*pa, "velocity"), 1e-3); // a phase at rest: 1 mm/s
    const FieldDiff dx = compare_field(*pa, *pb, "position", match);
    const FieldDiff dv = compare_field(*pa, *pb, "velocity", match);
    std::printf("  %s (%zu): position %.3e m = %.3e %s (id %llu), velocity %.3e m/s = %.3e of "
                "the largest speed %.3g m/s (id %llu)\n",
                phase, match.size(), dx.max, dx.max / length, fluid ? "dp" : "contact radii",
                static_cast<unsigned long long>(dx.worst_id), dv.max, dv.max / speed, speed,
                static_cast<unsigned long long>(dv.worst_id));
    report(std::string(phase) + "_position_rel", dx.max / length);
    report(std::string(phase) + "_velocity_rel", dv.max / speed);
    EXPECT_EQ(dx.nonfinite + dv.nonfinite, 0u) << phase << ": NaN or inf";
    EXPECT_LE(dx.max / length, tol.position) << phase << " position, worst id " << dx.worst_id;
    EXPECT_LE(dv.max / speed, tol.velocity) << phase << " velocity, worst id " << dv.worst_id;
    if (fluid) {
      const FieldDiff dr = compare_field(*pa, *pb, "density", match);
      const double rho0 = s.fluid.rest_density;
      std::printf("  fluid density %.3e kg/m^3 = %.3e rho0 (id %llu)\n", dr.max, dr.max / rho0,
                  static_cast<unsigned long long>(dr.worst_id));
      report("fluid_density_rel", dr.max / rho0);
      EXPECT_EQ(dr.nonfinite, 0u) << "fluid density: NaN or inf";
      EXPECT_LE(dr.max / rho0, tol.density) << "fluid density, worst id " << dr.worst_id;
    } else if (pa->find("saturation") != nullptr) {
      const FieldDiff ds = compare_field(*pa, *pb, "saturation", match);
      double s_max = 0;
      for (double q : values(*pa, "saturation"))
        s_max = std::max(s_max, q);
      std::printf("  knit saturation %.3e (largest %.3f) (id %llu)\n", ds.max, s_max,
                  static_cast<unsigned long long>(ds.worst_id));
      report("knit_saturation_abs", ds.max);
      EXPECT_GT(s_max, 0.0) << "the knit never got wet: the comparison tests little";
      EXPECT_EQ(ds.nonfinite, 0u) << "saturation: NaN or inf";
      EXPECT_LE(ds.max, tol.saturation) << "saturation, worst id " << ds.worst_id;
    }
  }
  EXPECT_GT(phases, 0) << "nothing compared";
}

INSTANTIATE_TEST_SUITE_P(Scenes, Backends, ::testing::ValuesIn(cases()),
                         [](const ::testing::TestParamInfo<Case>& i) { return i.param.name; });

// Out of GPU memory. Not provoked through a scene: Simulation::create (and Simulation::plan)
// sample the fluid on the host first, in double (48 bytes per particle, plus the copies converted
// for upload), about as many bytes as the device then needs, so a scene beyond an 80-141 GB GPU
// would need most of the device machine's 128 GB of host memory and minutes of sampling before
// the first device allocation. The failure is provoked where every device allocation goes
// instead: a DeviceBuffer of 1 TiB, more than any single GPU holds.
TEST(BackendsOutOfMemory, HugeGpuBufferThrowsNamedErrorAndTheDeviceStaysUsable) {
  if (!exec::cuda_compiled() || !exec::cuda_available())
    GTEST_SKIP() << "no CUDA device: GPU out-of-memory test skipped";
  const std::size_t n = std::size_t(1) << 38; // floats: 1 TiB
  const std::size_t bytes = n * sizeof(float);
  try {
    exec::DeviceBuffer<float> huge(exec::Backend::Cuda, n, "test.huge");
    FAIL() << "allocating " << bytes << " bytes on the GPU succeeded";
  } catch (const Error& e) {
    const std::string msg = e.what();
    std::printf("out of memory: %s\n", msg.c_str());
    EXPECT_NE(msg.find("out of GPU memory"), std::string::npos) << msg;
    EXPECT_NE(msg.find("test.huge"), std::string::npos) << msg;
    EXPECT_NE(msg.find(std::to_string(bytes)), std::string::npos) << msg;
  }

  // Still usable: a small buffer takes a poison pattern and then data, and both come back ...
  exec::DeviceBuffer<float> small(exec::Backend::Cuda, 1000, "test.small");
  small.poison();
  const std::vector<float> poisoned = small.to_host();
  std::uint32_t bits = 0;
  std::memcpy(&bits, &poisoned.back(), sizeof bits);
  EXPECT_EQ(bits, 0xFFFFFFFFu);
  std::vector<float> h(1000);
  for (std::size_t i = 0; i < h.size(); ++i)
    h[i] = static_cast<float>(i);
  small.assign(h);
  EXPECT_EQ(small.to_host(), h);
  // ... and a small simulation runs.
  const Scene s = load_scene((test::source_dir() / "scenes" / "dambreak.toml").string(),
                             {"output.enabled=false", "fluid.spacing=0.02"});
  auto sim = Simulation::create(s, exec::Backend::Cuda);
  for (int k = 0; k < 20; ++k)
    sim->step(s.end_time);
  const Diagnostics d = sim->diagnostics();
  EXPECT_EQ(d.fluid, Simulation::plan(s).fluid);
  EXPECT_TRUE(std::isfinite(d.kinetic_energy) && d.kinetic_energy > 0);
  EXPECT_EQ(sim->steps(), 20u);
}
