// The threaded CPU path: ctest runs every other test program with one OpenMP thread, so this one
// runs the dam break, the drape and the pour (paper model) with 2 threads against 1 on the same
// scene. Every kernel gathers (each particle sums what acts on it, no atomics), sorts are by
// (key, index) and dt is a minimum, so the threads change no sum's order: the state after 200
// steps must be the same bit for bit, every field of every phase. A looser bound would hide a
// race (two threads writing one element) that only shows under load.
#include "domain/Simulation.hpp"
#include "support/TestPaths.hpp"

#include <gtest/gtest.h>
#include <omp.h>

#include <cstdio>
#include <string>
#include <vector>

using namespace kf;

namespace {

struct Outcome {
  io::Frame frame;
  Diagnostics diag;
};

Outcome run_with_threads(const Scene& s, int threads, int steps) {
  const int before = omp_get_max_threads();
  omp_set_num_threads(threads);
  EXPECT_EQ(omp_get_max_threads(), threads);
  auto sim = Simulation::create(s, exec::Backend::Cpu);
  for (int k = 0; k < steps; ++k)
    sim->step(1e9);
  Outcome o{sim->frame(), sim->diagnostics()};
  omp_set_num_threads(before);
  return o;
}

struct ThreadCase {
  const char* name;
  const char* file;
  std::vector<std::string> overrides; // coarsened so 2 x 200 steps take seconds
};

class Threads : public ::testing::TestWithParam<ThreadCase> {};

} // namespace

TEST_P(Threads, TwoThreadsGiveTheSameStateAsOneBitForBit) {
  const ThreadCase& c = GetParam();
  std::vector<std::string> sets = c.overrides;
  sets.push_back("output.enabled=false");
  const Scene s = load_scene((test::source_dir() / "scenes" / c.file).string(), sets);
  const int steps = 200;
  const Outcome run1 = run_with_threads(s, 1, steps), run2 = run_with_threads(s, 2, steps);
  const io::Frame &one = run1.frame, &two = run2.frame;
  ASSERT_EQ(one.step, static_cast<std::uint64_t>(steps));
  EXPECT_EQ(one.time, two.time) << "the threads changed a dt";
  ASSERT_EQ(one.phases.size(), two.phases.size());
  std::size_t fields = 0, rows = 0;
  for (std::size_t p = 0; p < one.phases.size(); ++p) {
    const io::Phase &a = one.phases[p], &b = two.phases[p];
    ASSERT_EQ(a.name, b.name);
    ASSERT_EQ(a.fields.size(), b.fields.size()) << a.name;
    for (std::size_t f = 0; f < a.fields.size(); ++f) {
      EXPECT_EQ(a.fields[f].name, b.fields[f].name);
      EXPECT_EQ(a.fields[f].count, b.fields[f].count) << a.name << "/" << a.fields[f].name;
      EXPECT_TRUE(a.fields[f].bytes == b.fields[f].bytes)
          << a.name << "/" << a.fields[f].name << " differs between 1 and 2 threads";
      ++fields;
      rows += a.fields[f].count;
    }
  }
  std::printf("%s: %d steps to t = %.5f s; %zu fields (%zu rows) identical with 1 and 2 threads\n",
              c.name, steps, one.time, fields, rows);
  // The pour is there for the coupling: it must have acted within the 200 steps.
  if (s.has(Module::Contact)) {
    EXPECT_GT(run1.diag.coupling_contacts, 0u) << "the fluid never touched the knit";
  }
}

INSTANTIATE_TEST_SUITE_P(
    Scenes, Threads,
    ::testing::Values(
        ThreadCase{"dambreak", "dambreak.toml", {"fluid.spacing=0.02"}},
        ThreadCase{"drape", "drape.toml", {"knit.piece.0.wales=32", "knit.piece.0.courses=32"}},
        ThreadCase{"pour",
                   "pour.toml",
                   {"fluid.spacing=0.012", "knit.piece.0.wales=24", "knit.piece.0.courses=24",
                    // the column's foot starts on the knit, so the coupling acts
                    "fluid.block.0.min=[-0.04, -0.04, 0.535]",
                    "fluid.block.0.max=[0.04, 0.04, 0.8]"}}),
    [](const auto& info) { return std::string(info.param.name); });
