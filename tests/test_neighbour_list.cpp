// The fluid's neighbour lists change where the SPH passes find their neighbours, not what they
// compute: a dam break with solver.neighbour_list "on" and "off" must agree bit for bit (the
// list keeps the grid's candidate order, so every sum adds the same terms in the same order).
#include "domain/Scene.hpp"
#include "domain/Simulation.hpp"
#include "io/Frame.hpp"
#include "support/TestPaths.hpp"

#include <gtest/gtest.h>

#include <cstring>
#include <string>

using namespace kf;

namespace {

io::Frame run(const std::string& lists, const std::string& precision) {
  const Scene s = load_scene((test::source_dir() / "scenes" / "dambreak.toml").string(),
                             {"output.enabled=false", "fluid.spacing=0.02",
                              "solver.neighbour_list=\"" + lists + "\"",
                              "simulation.precision=\"" + precision + "\""});
  auto sim = Simulation::create(s, exec::Backend::Cpu);
  for (int k = 0; k < 150; ++k)
    sim->step(1e30);
  return sim->frame();
}

void expect_identical(const std::string& precision) {
  const io::Frame on = run("on", precision), off = run("off", precision);
  EXPECT_EQ(on.time, off.time);
  const io::Phase* a = on.find("fluid");
  const io::Phase* b = off.find("fluid");
  ASSERT_NE(a, nullptr);
  ASSERT_NE(b, nullptr);
  for (const char* name : {"position", "velocity", "density", "pressure", "id"}) {
    const io::Field* fa = a->find(name);
    const io::Field* fb = b->find(name);
    ASSERT_NE(fa, nullptr) << name;
    ASSERT_NE(fb, nullptr) << name;
    ASSERT_EQ(fa->bytes.size(), fb->bytes.size()) << name;
    EXPECT_EQ(std::memcmp(fa->bytes.data(), fb->bytes.data(), fa->bytes.size()), 0)
        << name << " differs between neighbour lists on and off (" << precision << ")";
  }
}

} // namespace

TEST(NeighbourList, SameDamBreakBitForBitFloat) {
  expect_identical("float");
}
TEST(NeighbourList, SameDamBreakBitForBitDouble) {
  expect_identical("double");
}
