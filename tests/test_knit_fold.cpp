// Knit self-collision in a whole simulation: a tall strip dropped on its end crumples onto the
// floor in folds. With self-collision its sheets never pass through each other (zero crossings of
// its profile, layers in order); without, the same drop does pass through (the check can fail).
#include "domain/KnitBuilder.hpp"
#include "domain/Simulation.hpp"
#include "support/KnitChecks.hpp"
#include "support/KnitScenes.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

using namespace kf;

namespace {

struct FoldResult {
  std::size_t worst_crossings = 0, worst_layer_swaps = 0;
  std::size_t worst_local_crossings = 0; // layers of one spot sheared across each other
  double end_height = 0;                 // highest point at the end [m]
  std::uint64_t self_contacts = 0;
  double min_gap = 1e30;
  bool finite = true;
};

Scene fold_scene(bool self_collision) {
  // 0.6 m tall, its foot 12 mm above the floor; a slot as wide as the strip: it folds in the
  // x-z plane (the profile the check looks at).
  Scene s = test::falling_strip(0.6, 90, 0.012, self_collision);
  s.end_time = 1.2;
  return s;
}

FoldResult drop(bool self_collision) {
  const Scene s = fold_scene(self_collision);
  const KnitMesh mesh = build_knit(s);
  const KnitPieceLayout L = mesh.pieces[0];
  auto sim = Simulation::create(s, exec::Backend::Cpu);
  FoldResult r;
  long step = 0;
  auto check = [&] {
    const io::Frame fr = sim->frame();
    const auto x = test::as_points(fr.find("knit")->find("position")->as<float>());
    for (const Vec3d& q : x)
      r.finite = r.finite && std::isfinite(q.x) && std::isfinite(q.y) && std::isfinite(q.z);
    r.worst_crossings =
        std::max(r.worst_crossings, test::profile_crossings(x, L, {1, 0, 0}, {0, 0, 1}));
    r.worst_local_crossings =
        std::max(r.worst_local_crossings, test::profile_crossings(x, L, {1, 0, 0}, {0, 0, 1}, 0) -
                                              test::profile_crossings(x, L, {1, 0, 0}, {0, 0, 1}));
    r.worst_layer_swaps = std::max(r.worst_layer_swaps, test::layer_order_violations(x, mesh.x, L));
    r.end_height = 0;
    for (const Vec3d& q : x)
      r.end_height = std::max(r.end_height, q.z);
    const Diagnostics d = sim->diagnostics();
    r.self_contacts = std::max(r.self_contacts, d.knit_self_contacts);
    r.min_gap = std::min(r.min_gap, d.knit_self_min_gap);
  };
  while (sim->time() < s.end_time && r.finite) {
    sim->step(s.end_time);
    if (++step % 200 == 0)
      check();
  }
  check();
  std::printf("self-collision %s: %ld steps, worst profile crossings %zu (sheet through sheet), "
              "%zu (layers of one spot sheared across), layer swaps %zu, highest point at the "
              "end %.3f m, most contacts %llu, closest pair %.3f x 2R\n",
              self_collision ? "on" : "off", step, r.worst_crossings, r.worst_local_crossings,
              r.worst_layer_swaps, r.end_height, static_cast<unsigned long long>(r.self_contacts),
              r.min_gap);
  return r;
}

} // namespace

TEST(KnitFold, AStripCrumplingOntoItselfNeverPassesThroughItself) {
  const FoldResult on = drop(true);
  ASSERT_TRUE(on.finite);
  EXPECT_LT(on.end_height, 0.2) << "the strip did not fall and fold";
  EXPECT_GT(on.self_contacts, 100u) << "the folds never touched: the test tests nothing";
  EXPECT_EQ(on.worst_crossings, 0u);
  EXPECT_EQ(on.worst_layer_swaps, 0u);
  EXPECT_GT(on.min_gap, 0.5) << "a pair got closer than R: near pass-through";
}

// The same drop without self-collision passes through itself: the crossing count sees it.
TEST(KnitFold, WithoutSelfCollisionTheSameDropPassesThroughItself) {
  const FoldResult off = drop(false);
  ASSERT_TRUE(off.finite);
  EXPECT_GT(off.worst_crossings, 0u);
}
