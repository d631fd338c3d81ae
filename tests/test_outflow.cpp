// Fluid leaving the domain through a side without a wall is removed and counted: what remains
// plus what left is the initial mass; nothing leaves through a side with a wall; the remaining
// particles keep their ids and fields.
#include "domain/Simulation.hpp"
#include "support/SceneFactory.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <set>
#include <string>

using namespace kf;

namespace {

// Outflow is removed in the fluid's sort (grid.fluid), which says so in the plan only when a side
// is open: the one place the pipeline shows whether removal runs.
std::string sort_stage_says(const Simulation& sim) {
  for (const auto& st : sim.pipeline().stages())
    if (st.name == "grid.fluid")
      return st.what;
  return "<no grid.fluid stage>";
}
constexpr const char* kRemoves = "remove fluid that left the domain";

std::map<std::uint64_t, double> mass_by_id(const Simulation& sim) {
  const io::Frame fr = sim.frame();
  const auto m = fr.find("fluid")->find("mass")->as<double>();
  const auto id = fr.find("fluid")->find("id")->as<std::uint64_t>();
  std::map<std::uint64_t, double> r;
  for (std::size_t i = 0; i < id.size(); ++i)
    r[id[i]] = m[i];
  return r;
}
} // namespace

TEST(Outflow, FluidThroughAnOpenSideIsRemovedAndCounted) {
  const Scene sc = test::jet_scene(R"("x-", "y-", "y+", "z-", "z+")");
  auto sim = Simulation::create(sc, exec::Backend::Cpu);
  EXPECT_NE(sort_stage_says(*sim).find(kRemoves), std::string::npos) << sort_stage_says(*sim);
  const Diagnostics d0 = sim->diagnostics();
  const io::Frame f0 = sim->frame();
  ASSERT_NE(f0.find("fluid"), nullptr);
  ASSERT_NE(f0.find("fluid")->find("mass"), nullptr);
  const auto m0 = f0.find("fluid")->find("mass")->as<double>();
  double mass0 = 0;
  for (double m : m0)
    mass0 += m;
  // 2 m/s for 0.025 s: the block (particles at x = 0.125 .. 0.175) moves 5 cm, half past 0.2.
  while (sim->time() < 0.025)
    sim->step(0.025);
  const Diagnostics d = sim->diagnostics();
  ASSERT_GT(d.fluid, 0u) << "everything left";
  const io::Frame fr = sim->frame();
  const io::Phase* fl = fr.find("fluid");
  ASSERT_NE(fl, nullptr);
  for (const char* f : {"mass", "position", "id"})
    ASSERT_NE(fl->find(f), nullptr) << f;
  const auto m = fr.find("fluid")->find("mass")->as<double>();
  const auto x = fr.find("fluid")->find("position")->as<double>();
  const auto id = fr.find("fluid")->find("id")->as<std::uint64_t>();
  double mass = 0;
  for (double q : m)
    mass += q;
  std::printf("%zu particles -> %zu, %llu left (%.4g kg); mass %.6g + %.6g = %.6g of %.6g kg\n",
              d0.fluid, d.fluid, static_cast<unsigned long long>(d.outflow_particles),
              d.outflow_mass, mass, d.outflow_mass, mass + d.outflow_mass, mass0);
  EXPECT_GE(d.outflow_particles, d0.fluid / 4) << "the jet did not leave";
  EXPECT_GT(d.fluid, d0.fluid / 4) << "the rear of the jet left too";
  EXPECT_EQ(d.fluid + d.outflow_particles, d0.fluid);
  EXPECT_NEAR(mass + d.outflow_mass, mass0, 1e-12 * mass0);
  for (std::size_t i = 0; i < m.size(); ++i)
    EXPECT_LE(x[3 * i], 0.2) << "a particle outside the domain was kept";
  EXPECT_EQ(std::set<std::uint64_t>(id.begin(), id.end()).size(), id.size()) << "ids repeat";
  EXPECT_LT(*std::max_element(id.begin(), id.end()), d0.fluid);
}

// The jet hits the x+ wall: the sort removes nothing (it is told not to, and the plan says so),
// and every particle is kept with its id and its mass, to the bit.
TEST(Outflow, NothingLeavesThroughAWall) {
  auto sim = Simulation::create(test::jet_scene(R"("x-", "x+", "y-", "y+", "z-", "z+")"),
                                exec::Backend::Cpu);
  const std::string says = sort_stage_says(*sim);
  ASSERT_NE(says.find("sort fluid by cell"), std::string::npos) << says;
  EXPECT_EQ(says.find(kRemoves), std::string::npos) << "a closed box removes fluid: " << says;
  const std::size_t n0 = sim->diagnostics().fluid;
  const auto m0 = mass_by_id(*sim);
  ASSERT_EQ(m0.size(), n0);
  double reach = 0; // how near the jet came to the wall at x = 0.2
  while (sim->time() < 0.05) {
    sim->step(0.05);
    const auto x = sim->frame().find("fluid")->find("position")->as<double>();
    for (std::size_t i = 0; i < x.size(); i += 3)
      reach = std::max(reach, x[i]);
  }
  const Diagnostics d = sim->diagnostics();
  EXPECT_GT(reach, 0.195) << "the jet never came to the wall";
  EXPECT_GE(d.fluid_sorts, sim->steps()) << "not sorted every step";
  EXPECT_EQ(d.fluid, n0);
  EXPECT_EQ(d.outflow_particles, 0u);
  EXPECT_EQ(d.outflow_mass, 0.0);
  EXPECT_EQ(mass_by_id(*sim), m0) << "a particle was lost, renumbered or changed mass";
}

// With "verlet" lists, fluid that left is removed at the next sort (a removal renumbers the
// fluid, so removing at once built the lists again at every step something left): the count and
// the mass still add up, every removal falls on a step that sorted anyway, and what is kept
// meanwhile lies at most the skin outside.
TEST(Outflow, VerletListsRemoveAtTheNextSort) {
  const Scene sc =
      test::jet_scene(R"("x-", "y-", "y+", "z-", "z+")", R"(neighbour_list = "verlet")");
  auto sim = Simulation::create(sc, exec::Backend::Cpu);
  const Diagnostics d0 = sim->diagnostics();
  auto fluid_mass = [&] {
    double sum = 0;
    for (double q : sim->frame().find("fluid")->find("mass")->as<double>())
      sum += q;
    return sum;
  };
  const double mass0 = fluid_mass();
  const double skin = sc.solver.neighbour_skin * sc.support_radius();
  std::uint64_t removals = 0, outside_steps = 0;
  double beyond = 0;
  Diagnostics last = d0;
  while (sim->time() < 0.025) {
    sim->step(0.025);
    const Diagnostics d = sim->diagnostics();
    if (d.outflow_particles > last.outflow_particles) {
      ++removals;
      EXPECT_GT(d.fluid_sorts, last.fluid_sorts)
          << "a removal without a sort, step " << sim->steps();
    }
    const auto x = sim->frame().find("fluid")->find("position")->as<double>();
    double out = 0;
    for (std::size_t i = 0; i < x.size(); i += 3)
      out = std::max(out, x[i] - 0.2);
    outside_steps += out > 0;
    beyond = std::max(beyond, out);
    last = d;
  }
  const Diagnostics d = sim->diagnostics();
  std::printf("%llu left in %llu removals over %llu steps (%llu sorts); kept outside over %llu "
              "steps, up to %.3g mm (skin %.3g mm)\n",
              static_cast<unsigned long long>(d.outflow_particles),
              static_cast<unsigned long long>(removals),
              static_cast<unsigned long long>(sim->steps()),
              static_cast<unsigned long long>(d.fluid_sorts),
              static_cast<unsigned long long>(outside_steps), 1e3 * beyond, 1e3 * skin);
  EXPECT_GE(d.outflow_particles, d0.fluid / 4) << "the jet did not leave";
  EXPECT_EQ(d.fluid + d.outflow_particles, d0.fluid);
  EXPECT_NEAR(fluid_mass() + d.outflow_mass, mass0, 1e-12 * mass0);
  EXPECT_GT(outside_steps, 0u) << "nothing was ever kept outside: the removal was not deferred";
  EXPECT_LE(beyond, skin) << "a particle more than the skin outside was kept";
}
