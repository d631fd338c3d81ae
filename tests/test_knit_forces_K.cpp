// The knit's force pass in one launch (KnitPointForces: springs, volume cells and gravity, with
// self-contact and the fluid's coupling) against the separate passes it replaces, run one after
// the other on the same state: the knit's accelerations and the fluid's impulses bit for bit
// (the one pass does each term's arithmetic in the same order), every point written (a NaN
// fill); with the coupling, the self-contact's copies gathered in the coupling's pass. On the CPU,
// and on the GPU when one is present.
#include "kernels/coupling/KnitFluidCoupling.hpp"
#include "kernels/knit/Knit.hpp"
#include "kernels/knit/SelfContact.hpp"
#include "support/Backends.hpp"
#include "support/Bits.hpp"
#include "support/VecCast.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

using namespace kf;

namespace {

constexpr double kR = 0.002; // the knit's contact radius
constexpr double kH = 0.01;  // the fluid's smoothing length
constexpr int kSide = 24;    // points a side of each sheet

/// Two sheets of the same piece folded onto each other 1.5 R apart (self-contact between them,
/// none within a sheet: its rest neighbours are excluded), each sheet's points joined by
/// stretch and shear springs, every 13th point on a handle; fluid in and around the fold.
struct Scene {
  std::vector<Vec3d> x, v, rest, fx, fv;
  std::vector<double> m, fm, frho;
  std::vector<std::uint32_t> handle;
  std::vector<Spring> springs;
};

Scene make_scene() {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  Scene s;
  const double dx = 0.004; // 2 R: stretch springs at rest length dx
  for (int layer = 0; layer < 2; ++layer)
    for (int i = 0; i < kSide; ++i)
      for (int j = 0; j < kSide; ++j) {
        const Vec3d at{i * dx, j * dx, 0.05 + layer * 1.5 * kR};
        s.x.push_back(at + Vec3d{u(rng), u(rng), u(rng)} * (0.1 * dx));
        // Rest positions: the sheets lie far apart on the rest mesh (folded), so their points
        // may touch; within a sheet, neighbours are excluded.
        s.rest.push_back(at + Vec3d{0, 0, layer * 0.5});
        s.v.push_back(Vec3d{u(rng), u(rng), u(rng)} * 0.05);
        s.m.push_back(2e-5 * (1.2 + 0.3 * u(rng)));
        s.handle.push_back(s.handle.size() % 13 == 0 ? 0u : kFreePoint);
      }
  auto index = [](int layer, int i, int j) {
    return static_cast<std::uint32_t>((layer * kSide + i) * kSide + j);
  };
  for (int layer = 0; layer < 2; ++layer)
    for (int i = 0; i < kSide; ++i)
      for (int j = 0; j < kSide; ++j) {
        if (i + 1 < kSide)
          s.springs.push_back({index(layer, i, j), index(layer, i + 1, j), dx, 40, 1e-3});
        if (j + 1 < kSide)
          s.springs.push_back({index(layer, i, j), index(layer, i, j + 1), dx, 40, 1e-3});
        if (i + 1 < kSide && j + 1 < kSide)
          s.springs.push_back({index(layer, i, j), index(layer, i + 1, j + 1), dx * std::sqrt(2.0),
                               5, 2e-4, SpringKind::Shear});
      }
  for (int q = 0; q < 1200; ++q) {
    const double w = kSide * dx;
    s.fx.push_back({w * (0.5 + 0.5 * u(rng)), w * (0.5 + 0.5 * u(rng)), 0.05 + 0.006 * u(rng)});
    s.fv.push_back(Vec3d{u(rng), u(rng), u(rng)} * 0.3);
    s.fm.push_back(1.25e-4 * (1 + 0.2 * u(rng)));
    s.frho.push_back(1000 * (1 + 0.1 * u(rng)));
  }
  return s;
}

template <typename T>
void check(exec::Backend backend) {
  const Scene sc = make_scene();
  const std::size_t n = sc.x.size(), nf = sc.fx.size();
  exec::Exec ex{backend};
  KnitSet<T> knit(backend);
  knit.resize(n);
  knit.x.assign(test::vec_cast_all<T>(sc.x));
  knit.v.assign(test::vec_cast_all<T>(sc.v));
  knit.x_rest.assign(test::vec_cast_all<T>(sc.rest));
  knit.m.assign(std::vector<T>(sc.m.begin(), sc.m.end()));
  knit.piece.assign(std::vector<std::uint16_t>(n, 0));
  knit.handle.assign(sc.handle);
  std::vector<std::uint64_t> kid(n);
  for (std::size_t i = 0; i < n; ++i)
    kid[i] = i;
  knit.id.assign(kid);
  SpringTopology<T> springs(backend);
  springs.build(sc.springs, n);
  const Vec3<T> g{T(0), T(0), T(-9.81)};

  SelfContactParams<T> sp{T(kR), T(9 * kR * kR), T(60), T(0.3), T(0.4)};
  KnitSelfContact<T> self(
      backend, NeighbourGrid<T>::cover({-0.01, -0.01, 0.03}, {0.11, 0.11, 0.07}, 3 * kR), sp);
  self.sync(ex, knit);

  FluidSet<T> fluid(backend);
  fluid.resize(nf);
  fluid.x.assign(test::vec_cast_all<T>(sc.fx));
  fluid.v.assign(test::vec_cast_all<T>(sc.fv));
  fluid.a.assign(std::vector<Vec3<T>>(nf, Vec3<T>{}));
  fluid.m.assign(std::vector<T>(sc.fm.begin(), sc.fm.end()));
  fluid.p.assign(std::vector<T>(nf, T(0)));
  std::vector<std::uint64_t> fid(nf);
  for (std::size_t i = 0; i < nf; ++i)
    fid[i] = i;
  fluid.id.assign(fid);
  NeighbourGrid<T> fluid_grid(
      backend, NeighbourGrid<T>::cover({-0.01, -0.01, 0.03}, {0.11, 0.11, 0.07}, kH));
  fluid_grid.build(ex, fluid.x.data(), nf);
  fluid.reorder(ex, fluid_grid.permutation());
  fluid.rho.assign(std::vector<T>(sc.frho.begin(), sc.frho.end())); // any density will do
  const FluidSide<T> side{fluid.view(), fluid_grid.view()};

  CouplingParams<T> cpp;
  cpp.contact = true;
  cpp.capillary = true;
  cpp.reach = T(0.003);
  cpp.dem = {T(200), T(0.4), T(0.3)};
  cpp.h = T(kH);
  cpp.porosity = T(0.7);
  cpp.rho0 = T(1000);
  cpp.pressure_scale = T(2000);
  cpp.volume_per_mass = T(0.01);
  cpp.gravity = g;
  KnitFluidCoupling<T> cp(
      backend, KernelType::Spiky, cpp,
      NeighbourGrid<T>::cover({-0.01, -0.01, 0.03}, {0.11, 0.11, 0.07}, T(1.2) * T(kH)));
  const T weight = T(0.25);
  const T nan = std::numeric_limits<T>::quiet_NaN();
  const std::vector<Vec3<T>> poison(n, Vec3<T>{nan, nan, nan});
  const auto terms = [&] {
    return KnitForceTerms<T>{{knit.view(), springs.view(), {}, g}, self.evaluator(knit), true};
  };

  // Springs and self-contact: two passes, then one.
  knit.a.assign(poison);
  knit_forces(ex, knit.view(), springs.view(), g);
  self.update(ex, knit);
  self.add_forces(ex, knit);
  const auto a_two = knit.a.to_host();
  knit.a.assign(poison);
  self.update(ex, knit);
  knit_forces(ex, n, terms());
  const auto a_one = knit.a.to_host();
  // Past kKnitOnePassUpTo points the same sums take two passes (forced here).
  knit.a.assign(poison);
  self.update(ex, knit);
  knit_forces(ex, n, terms(), 0);
  EXPECT_TRUE(test::same_bits(knit.a.to_host(), a_one)) << "springs + self-contact, two passes";
  // The premise: the fold's sheets touch.
  const SelfContactStats st = self.stats(ex, knit);
  EXPECT_GT(st.contacts, 100u) << "too few self-contacts to test";
  EXPECT_TRUE(test::same_bits(a_one, a_two)) << "springs + self-contact in one pass";
  for (std::size_t i = 0; i < n; ++i)
    ASSERT_TRUE(std::isfinite(a_one[i].x) && std::isfinite(a_one[i].y) && std::isfinite(a_one[i].z))
        << "point " << i << " not written";

  // With the coupling: the separate passes (springs, self-contact, the coupling adding its
  // share), then the coupling's pass taking the knit's own terms and gathering both structures'
  // copies. Each from the same state: both structures sorted and gathered at x0, the knit then
  // moved within their skins (so copies left ungathered would give other forces), begin_step's
  // impulses cleared.
  self.begin_step(ex, knit, T(0)); // no motion expected: the substeps watch on the device
  ASSERT_FALSE(self.checks_on_host()) << "the premise: the self-contact's copies gathered on the "
                                         "device, in the coupling's pass";
  std::vector<Vec3<T>> x1 = test::vec_cast_all<T>(sc.x);
  {
    std::mt19937 rng(17);
    std::uniform_real_distribution<double> u(-1, 1);
    // Under half of both skins: the self-contact's 0.5 R, the coupling's (1.2 h - h) / 3.
    const double step = 0.4 * std::min(0.5 * kR, 0.2 * kH / 3);
    for (auto& q : x1)
      q += vec_cast<T>(Vec3d{u(rng), u(rng), u(rng)} * step);
  }
  auto coupled = [&](bool one_pass, std::vector<Vec3<T>>& a, std::vector<Vec3<T>>& v) {
    fluid.v.assign(test::vec_cast_all<T>(sc.fv)); // in grid order below: only compared with itself
    knit.x.assign(test::vec_cast_all<T>(sc.x));
    cp.begin_step(ex, knit, side, {}, T(0));
    self.update(ex, knit); // the copies at x0
    knit.x.assign(x1);
    knit.a.assign(poison);
    if (one_pass) {
      const WatchedCopies<T> copies = self.update_copies(ex, knit);
      EXPECT_NE(copies.watch, nullptr);
      const KnitForceTerms<T> own = terms();
      cp.add_forces(ex, knit, side, weight, &own, copies);
    } else {
      knit_forces(ex, knit.view(), springs.view(), g);
      self.update(ex, knit);
      self.add_forces(ex, knit);
      cp.add_forces(ex, knit, side, weight);
    }
    cp.apply_impulses(ex, fluid.view());
    a = knit.a.to_host();
    v = fluid.v.to_host();
  };
  std::vector<Vec3<T>> a_sep, v_sep, a_fused, v_fused;
  coupled(false, a_sep, v_sep);
  coupled(true, a_fused, v_fused);
  const CouplingStats cs = cp.stats(ex, knit, side);
  EXPECT_GT(cs.contacts, 50u) << "too few fluid-knit contacts to test";
  EXPECT_GT(cs.wet_points, n / 4) << "too little fluid around the knit to test";
  EXPECT_TRUE(test::same_bits(a_fused, a_sep)) << "springs + self-contact + coupling in one pass";
  EXPECT_TRUE(test::same_bits(v_fused, v_sep)) << "the fluid's impulses";
  EXPECT_FALSE(test::same_bits(a_fused, a_one))
      << "the coupling added nothing: the test sees nothing";
  EXPECT_EQ(cp.sorts(), 1u) << "the coupling's grid must stay as begin_step first sorted it";
  EXPECT_EQ(self.sorts(), 1u) << "the self-contact's grid must stay as first sorted";
  std::size_t held = 0;
  for (std::size_t i = 0; i < n; ++i) {
    ASSERT_TRUE(std::isfinite(a_fused[i].x) && std::isfinite(a_fused[i].y) &&
                std::isfinite(a_fused[i].z))
        << "point " << i << " not written";
    if (sc.handle[i] != kFreePoint) {
      EXPECT_EQ(a_fused[i].x, T(0));
      EXPECT_EQ(a_fused[i].z, T(0));
      ++held;
    }
  }
  EXPECT_GT(held, 50u);
}

} // namespace

TEST(KnitForces, OnePassIsTheSeparatePassesFloat) {
  for (const exec::Backend b : test::backends()) {
    SCOPED_TRACE(b == exec::Backend::Cpu ? "cpu" : "cuda");
    check<float>(b);
  }
}

TEST(KnitForces, OnePassIsTheSeparatePassesDouble) {
  for (const exec::Backend b : test::backends()) {
    SCOPED_TRACE(b == exec::Backend::Cpu ? "cpu" : "cuda");
    check<double>(b);
  }
}
