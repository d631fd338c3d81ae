// Knit-fluid coupling kernels (Eq. 7-12; DESIGN §10) against independent all-pairs references:
// the knit's saturation and pressure, the knit's accelerations and the fluid's impulses, pair
// forces that cancel; Leverett J's sign; and no capillary force from saturated knit. On the CPU,
// and on the GPU when one is present.
#include "kernels/coupling/KnitFluidCoupling.hpp"
#include "kernels/sph/SmoothingKernels.hpp"
#include "support/VecCast.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>

using namespace kf;

namespace {

constexpr double kH = 0.02;

struct Cloud {
  std::vector<Vec3d> kx, kv, fx, fv;
  std::vector<double> km, fm, frho;
  std::vector<std::uint32_t> handle;
};

/// Knit points in a sheet with fluid particles above, in and below it: most fluid particles have
/// several knit points within h and some within the contact reach.
Cloud make_cloud(unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  Cloud c;
  const double box = 0.1;
  for (int i = 0; i < 20; ++i)
    for (int j = 0; j < 20; ++j)
      for (int l = 0; l < 3; ++l) {
        c.kx.push_back(
            {box * (i + 0.3 * u(rng)) / 20, box * (j + 0.3 * u(rng)) / 20, 0.05 + 0.002 * (l - 1)});
        c.kv.push_back({0.2 * (u(rng) - 0.5), 0.2 * (u(rng) - 0.5), 0.2 * (u(rng) - 0.5)});
        c.km.push_back(2e-5 * (0.5 + u(rng)));
        c.handle.push_back(c.handle.size() % 29 == 0 ? 0u : kFreePoint);
      }
  for (int q = 0; q < 1500; ++q) {
    c.fx.push_back({box * u(rng), box * u(rng), 0.05 + 0.03 * (u(rng) - 0.5)});
    c.fv.push_back({u(rng) - 0.5, u(rng) - 0.5, u(rng) - 0.5});
    c.fm.push_back(1e-3 * (0.8 + 0.4 * u(rng)));
    c.frho.push_back(1000 * (0.9 + 0.2 * u(rng)));
  }
  return c;
}

CouplingParams<double> params() {
  CouplingParams<double> p;
  p.contact = true;
  p.capillary = true;
  p.reach = 0.006;
  p.dem = {200.0, 0.4, 0.3};
  p.h = kH;
  p.porosity = 0.7;
  p.rho0 = 1000;
  p.pressure_scale = 2000;
  p.volume_per_mass = 0.01;
  p.gravity = {0, 0, -9.81};
  return p;
}

/// params() in precision T.
template <typename T>
CouplingParams<T> params_in() {
  const auto p = params();
  CouplingParams<T> pt;
  pt.contact = p.contact;
  pt.capillary = p.capillary;
  pt.reach = T(p.reach);
  pt.dem = {T(p.dem.k), T(p.dem.zeta), T(p.dem.friction)};
  pt.h = T(p.h);
  pt.porosity = T(p.porosity);
  pt.rho0 = T(p.rho0);
  pt.pressure_scale = T(p.pressure_scale);
  pt.volume_per_mass = T(p.volume_per_mass);
  pt.gravity = vec_cast<T>(p.gravity);
  return pt;
}

template <typename T>
struct Fixture {
  exec::Exec ex;
  KnitSet<T> knit;
  FluidSet<T> fluid;
  NeighbourGrid<T> fluid_grid;
  Fixture(exec::Backend b, const Cloud& c)
      : ex{b}, knit(b), fluid(b),
        fluid_grid(b, NeighbourGrid<T>::cover({0, 0, 0}, {0.1, 0.1, 0.1}, kH)) {
    const std::size_t n = c.kx.size(), nf = c.fx.size();
    knit.resize(n);
    knit.x.assign(test::vec_cast_all<T>(c.kx));
    knit.x_rest.assign(test::vec_cast_all<T>(c.kx));
    knit.v.assign(test::vec_cast_all<T>(c.kv));
    knit.m.assign(std::vector<T>(c.km.begin(), c.km.end()));
    knit.handle.assign(c.handle);
    knit.a.assign(std::vector<Vec3<T>>(n, Vec3<T>{}));
    // The fluid as the coupling sees it after a sort: positions in grid order.
    fluid.resize(nf);
    fluid.x.assign(test::vec_cast_all<T>(c.fx));
    fluid.v.assign(test::vec_cast_all<T>(c.fv));
    fluid.a.assign(std::vector<Vec3<T>>(nf, Vec3<T>{}));
    fluid.m.assign(std::vector<T>(c.fm.begin(), c.fm.end()));
    fluid.rho.assign(std::vector<T>(c.frho.begin(), c.frho.end()));
    fluid.p.assign(std::vector<T>(nf, T(0)));
    std::vector<std::uint64_t> id(nf);
    for (std::size_t i = 0; i < nf; ++i)
      id[i] = i;
    fluid.id.assign(id);
    fluid_grid.build(ex, fluid.x.data(), nf);
    fluid.reorder(ex, fluid_grid.permutation());
    fluid.rho.assign(host_rho(c));
  }
  // rho is not carried by a reorder (it is recomputed after one): put it back in grid order.
  std::vector<T> host_rho(const Cloud& c) {
    const auto id = fluid.id.to_host();
    std::vector<T> r(id.size());
    for (std::size_t i = 0; i < id.size(); ++i)
      r[i] = T(c.frho[id[i]]);
    return r;
  }
  FluidSide<T> side() { return {fluid.view(), fluid_grid.view()}; }
};

/// Where the knit is when the forces are taken, against where its grid was sorted (begin_step).
enum class Motion {
  None,         // where begin_step saw it
  WithinSkin,   // every point moved less than the skin: the kept grid and near flags still hold
  PastListSkin, // every point moved 1.5-2.9 skins: past the lists' reach, within the cells'
                // margin (3 skins): the fluid side walks its cells, the knit side the fluid's
  PastMargin,   // every point moved 3.1-4 skins: a walk of the cells may miss a pair
  PastSkin,     // some points moved past the cells' margin, no sort: the fluid side sums over
                // all points
};

/// Where the coupling's lists are built for the fluid (begin_step's FluidAnchor).
enum class Anchor {
  None,   // where the fluid is now, every step
  Kept,   // an anchor each particle lies within 0.9 skins of: the lists built once for it
          // (begin_step twice, the second keeping them) hold every pair
  Outrun, // the anchor's bound past the skin: the lists are built for the fluid now, twice
};

template <typename T>
void check(exec::Backend backend, Motion motion = Motion::None, std::uint32_t list_capacity = 256,
           std::uint32_t knit_capacity = 0, Anchor anchor = Anchor::None, bool rows_short = false) {
  const Cloud c0 = make_cloud(5);   // saturation and pressure come from here (begin_step)
  Cloud c = c0;                     // the pair forces from here
  const double skin = 0.2 * kH / 3; // the knit grid's below: a third of its cells' margin
  {
    std::mt19937 rng(9);
    std::uniform_real_distribution<double> u(-1, 1);
    for (std::size_t i = 0; i < c.kx.size(); ++i) {
      const Vec3d r{u(rng), u(rng), u(rng) + 1e-3};
      const Vec3d dir = r * (1 / norm(r));
      if (motion == Motion::WithinSkin)
        c.kx[i] += dir * (0.9 * skin * std::abs(u(rng)));
      else if (motion == Motion::PastListSkin)
        c.kx[i] += dir * ((1.5 + 1.4 * std::abs(u(rng))) * skin);
      else if (motion == Motion::PastMargin)
        c.kx[i] += dir * ((3.1 + 0.9 * std::abs(u(rng))) * skin);
      else if (motion == Motion::PastSkin && i % 7 == 0)
        c.kx[i].x += c.kx[i].x < 0.05 ? 0.04 : -0.04; // 1.7 cells: out of their cells' reach
    }
  }
  const auto p = params();
  const CouplingParams<T> pt = params_in<T>();
  Fixture<T> fx(backend, c0);
  KnitFluidCoupling<T> cp(backend, KernelType::Spiky, pt,
                          NeighbourGrid<T>::cover({0, 0, 0}, {0.1, 0.1, 0.1}, 1.2 * kH),
                          list_capacity, knit_capacity);
  // The kernel adds to a (the springs' forces come first) and leaves pinned points alone, so a
  // NaN fill would only propagate: start from a distinct non-zero a instead. A free point must
  // end at its own start plus the coupling (not overwritten, not skipped when wet), a pinned one
  // at exactly its start (a zero start would let a written zero pass).
  std::vector<Vec3<T>> a0(c.kx.size());
  {
    std::mt19937 rng(13);
    std::uniform_real_distribution<double> u(-2, 2);
    for (auto& q : a0)
      q = {T(u(rng)), T(u(rng)), T(u(rng) - 9.81)};
  }
  fx.knit.a.assign(a0);
  // No motion expected over the step: the substeps watch the knit on the device only.
  if (anchor == Anchor::None) {
    if (rows_short) { // the first build finds the knit in a corner: rows for few particles
      fx.knit.x.assign(std::vector<Vec3<T>>(c0.kx.size(), Vec3<T>{T(0), T(0), T(0)}));
      cp.begin_step(fx.ex, fx.knit, fx.side(), {}, T(0));
      fx.knit.x.assign(test::vec_cast_all<T>(c0.kx));
    }
    // (rows_short: the knit has moved; a motion past the skin has the grid sorted again)
    cp.begin_step(fx.ex, fx.knit, fx.side(), {}, rows_short ? T(1) : T(0));
    EXPECT_EQ(cp.list_builds(), rows_short ? 2u : 1u);
  } else {
    // Where the fluid's lists were built: each particle up to 0.9 skins (Kept) from where it
    // is now, the fluid's order; the bound as the fluid's lists would report it.
    auto x0 = fx.fluid.x.to_host();
    std::mt19937 rng(21);
    std::uniform_real_distribution<double> u(-1, 1);
    double largest = 0;
    for (auto& q : x0) {
      const Vec3d r{u(rng), u(rng), u(rng) + 1e-3};
      const double d = (anchor == Anchor::Kept ? 0.9 : 1.5) * skin * std::abs(u(rng));
      q += vec_cast<T>(r * (d / norm(r)));
      largest = std::max(largest, d);
    }
    exec::DeviceBuffer<Vec3<T>> at(backend, 0, "test.anchor");
    at.assign(x0);
    const FluidAnchor<T> a{at.data(), 7, T(largest)};
    cp.begin_step(fx.ex, fx.knit, fx.side(), {}, T(0), {}, a);
    cp.begin_step(fx.ex, fx.knit, fx.side(), {}, T(0), {}, a);
    if (anchor == Anchor::Kept) {
      EXPECT_GT(largest, 0.8 * skin) << "the anchor tests little";
      EXPECT_EQ(cp.list_builds(), 1u) << "the anchor's lists must be kept";
      EXPECT_EQ(cp.flag_slack(), T(cp.skin()));
    } else {
      EXPECT_GT(largest, 1.0 * skin) << "the anchor's bound must pass the skin";
      EXPECT_EQ(cp.list_builds(), 2u) << "lists for an anchor past its bound";
      EXPECT_EQ(cp.flag_slack(), T(0));
    }
  }
  fx.knit.x.assign(test::vec_cast_all<T>(c.kx));
  const T weight = T(0.25);
  cp.add_forces(fx.ex, fx.knit, fx.side(), weight);
  EXPECT_EQ(cp.sorts(), rows_short ? 2u : 1u)
      << "the forces must come from the grid sorted at begin_step";
  if (rows_short) { // the premise: more near particles than rows, the knit's side walking
    std::uint32_t flag = 0;
    exec::copy_bytes(&flag, exec::Backend::Cpu, cp.knit_rows().incomplete(), backend, 4);
    EXPECT_GT(flag, 0u) << "the rows did not run short";
  }
  if (knit_capacity) { // the premise: some knit points read their listed pairs, some walk
    const ListView<T> rows = cp.knit_rows().view();
    std::vector<std::uint32_t> count(c.kx.size());
    exec::copy_bytes(count.data(), exec::Backend::Cpu, rows.count, backend, count.size() * 4);
    const auto over = std::count_if(count.begin(), count.end(),
                                    [&](std::uint32_t k) { return k > rows.capacity; });
    const auto listed = std::count_if(count.begin(), count.end(),
                                      [&](std::uint32_t k) { return k > 0 && k <= rows.capacity; });
    // Measured: 969 walk, 231 read their lists.
    EXPECT_GT(over, 800) << "too few knit points walk";
    EXPECT_GT(listed, 150) << "too few knit points read their lists";
    std::uint32_t flag = 1;
    exec::copy_bytes(&flag, exec::Backend::Cpu, cp.knit_rows().incomplete(), backend, 4);
    EXPECT_EQ(flag, 0u) << "every fluid row must fit: only the knit's rows overflow";
  }
  const auto a = fx.knit.a.to_host();
  const auto s = cp.saturation().to_host();
  const auto mfl = cp.fluid_mass().to_host();
  // The fluid's impulses, read back through v: v + J / m.
  const auto v0 = fx.fluid.v.to_host();
  cp.apply_impulses(fx.ex, fx.fluid.view());
  const auto v1 = fx.fluid.v.to_host();
  const auto fid = fx.fluid.id.to_host();

  // Reference, written out from the equations.
  const SpikyKernel<double> W(kH);
  const double tol = std::is_same_v<T, float> ? 3e-4 : 1e-10;
  const std::size_t n = c.kx.size(), nf = c.fx.size();
  std::vector<double> P(n);
  std::size_t wet = 0;
  for (std::size_t i = 0; i < n; ++i) {
    double rho = 0;
    for (std::size_t j = 0; j < nf; ++j) {
      const double r = norm(c0.kx[i] - c.fx[j]);
      if (r < kH)
        rho += c.fm[j] * W.W(r);
    }
    const double sat = rho / (p.porosity * p.rho0), u = 1 - sat;
    P[i] = p.pressure_scale * (1.417 * u - 2.120 * u * u + 1.263 * u * u * u);
    ASSERT_NEAR(s[i], sat, tol * (1 + sat)) << "saturation of knit point " << i;
    ASSERT_NEAR(mfl[i], c.km[i] * p.volume_per_mass * rho, tol * (1e-12 + mfl[i]));
    wet += sat > 0.05;
  }
  ASSERT_GT(wet, n / 4) << "too little fluid near the knit to test";
  auto pair = [&](std::size_t i, std::size_t j) { // force on fluid j from knit i
    Vec3d f{0, 0, 0};
    const Vec3d d = c.fx[j] - c.kx[i];
    const double r = norm(d);
    if (r < p.reach && r > 0) {
      const Vec3d nrm = d * (1 / r), dv = c.fv[j] - c.kv[i];
      const double mred = c.fm[j] * c.km[i] / (c.fm[j] + c.km[i]);
      const double gamma = 2 * std::sqrt(p.dem.k * mred), vn = dot(dv, nrm);
      const double fn = std::max(0.0, p.dem.k * (p.reach - r) - p.dem.zeta * gamma * vn);
      const Vec3d vt = dv - nrm * vn;
      f += nrm * fn;
      if (norm(vt) > 0)
        f -= vt * (std::min(p.dem.friction * fn, gamma * norm(vt)) / norm(vt));
    }
    if (r < kH && r > 0) // V_j V_i P_i grad_j W: toward the knit point when P > 0
      f += d * (W.dWdr(r) / r) * (c.fm[j] / c.frho[j] * c.km[i] * p.volume_per_mass * P[i]);
    return f;
  };
  std::vector<Vec3d> on_fluid(nf, Vec3d{0, 0, 0});
  Vec3d total{0, 0, 0};
  double fscale = 0;
  std::size_t contacts = 0;
  for (std::size_t i = 0; i < n; ++i) {
    Vec3d on_knit{0, 0, 0};
    for (std::size_t j = 0; j < nf; ++j) {
      const Vec3d f = pair(i, j);
      on_fluid[j] += f;
      on_knit -= f;
      contacts += norm(c.fx[j] - c.kx[i]) < p.reach;
    }
    const Vec3d weight_force =
        p.gravity * (c.km[i] * p.volume_per_mass * (s[i] * p.porosity * p.rho0)); // m_fluid g
    if (c.handle[i] != kFreePoint) {
      // Bitwise: an untouched element went through no arithmetic.
      ASSERT_TRUE(a[i].x == a0[i].x && a[i].y == a0[i].y && a[i].z == a0[i].z)
          << "pinned knit point " << i << " was written";
      fscale = std::max(fscale, norm(on_knit));
      total += on_knit;
      continue;
    }
    const Vec3d expect = (on_knit + weight_force) * (1 / c.km[i]);
    const Vec3d got = vec_cast<double>(a[i]) - vec_cast<double>(a0[i]); // the coupling's share
    ASSERT_LE(norm(got - expect), tol * (1 + norm(expect) + norm(vec_cast<double>(a0[i]))))
        << "knit point " << i;
    fscale = std::max(fscale, norm(on_knit));
    total += got * c.km[i] - weight_force;
  }
  ASSERT_GT(contacts, 200u) << "the contact is not exercised";
  for (std::size_t q = 0; q < nf; ++q) {
    const std::size_t j = fid[q];
    const Vec3d J = (vec_cast<double>(v1[q]) - vec_cast<double>(v0[q])) * c.fm[j];
    const Vec3d expect = on_fluid[j] * double(weight);
    ASSERT_LE(norm(J - expect), tol * (1e-3 + norm(expect)) * 4) << "fluid particle " << j;
    total += on_fluid[j];
  }
  // The knit's and the fluid's shares cancel.
  EXPECT_LT(norm(total), (std::is_same_v<T, float> ? 1e-3 : 1e-11) * fscale * std::sqrt(n));
  std::printf("%zu knit points (%zu wet), %zu fluid particles, %zu contacts: match\n", n, wet, nf,
              contacts);
}

/// The knit side's forces with and without fluid particles that are out of every knit point's
/// reach but inside the cells its walk visits (on N ranks a cell at the edge of the ghosts holds
/// only some of its particles): the same bit for bit on the CPU, whose sum meets the particles
/// in reach in the same order either way. Not on the GPU: the lanes of a knit point take its
/// candidates by place in the walk, so an extra particle shifts the lanes' shares and the sum by
/// rounding (dealing only the candidates in reach to the lanes makes it hold there too, but cost
/// the pour 6-9% on an H100: docs/PERFORMANCE.md, P5 stage 11).
template <typename T>
void knit_side_ignores_fluid_out_of_reach(exec::Backend backend) {
  const Cloud c = make_cloud(5);
  Cloud more = c;
  {
    std::mt19937 rng(21);
    std::uniform_real_distribution<double> u(0, 1);
    // The sheet spans z 0.048-0.052; these lie 0.022-0.026 above it, beyond h (0.02) and the
    // reach, in the cells a sheet point's walk visits (cells of h, one on each side).
    for (int q = 0; q < 800; ++q) {
      more.fx.push_back({0.1 * u(rng), 0.1 * u(rng), 0.074 + 0.004 * u(rng)});
      more.fv.push_back({u(rng) - 0.5, u(rng) - 0.5, u(rng) - 0.5});
      more.fm.push_back(1e-3);
      more.frho.push_back(1000);
    }
  }
  const CouplingParams<T> pt = params_in<T>();
  auto knit_a = [&](const Cloud& cloud, std::size_t* walked) {
    Fixture<T> fx(backend, cloud);
    KnitFluidCoupling<T> cp(backend, KernelType::Spiky, pt,
                            NeighbourGrid<T>::cover({0, 0, 0}, {0.1, 0.1, 0.1}, 1.2 * kH));
    fx.knit.a.assign(std::vector<Vec3<T>>(cloud.kx.size(), Vec3<T>{T(0), T(0), T(0)}));
    cp.begin_step(fx.ex, fx.knit, fx.side(), {}, T(0));
    cp.add_forces(fx.ex, fx.knit, fx.side(), T(0.25));
    // How many of the extra particles lie in the cells some knit point's walk visits (the
    // test's premise), from the grid's geometry on the host.
    const auto fxh = fx.fluid.x.to_host();
    const auto kxh = fx.knit.x.to_host();
    const auto id = fx.fluid.id.to_host();
    const GridGeometry<T>& geo = fx.fluid_grid.geometry();
    *walked = 0;
    for (std::size_t j = 0; j < fxh.size(); ++j) {
      if (id[j] < c.fx.size())
        continue;
      int a, b, d;
      geo.coords(fxh[j], a, b, d);
      for (const auto& q : kxh) {
        int qa, qb, qd;
        geo.coords(q, qa, qb, qd);
        if (std::abs(a - qa) <= 1 && std::abs(b - qb) <= 1 && std::abs(d - qd) <= 1) {
          ++*walked;
          break;
        }
      }
    }
    return fx.knit.a.to_host();
  };
  std::size_t walked0 = 0, walked1 = 0;
  const auto a0 = knit_a(c, &walked0);
  const auto a1 = knit_a(more, &walked1);
  ASSERT_EQ(walked0, 0u);
  ASSERT_GT(walked1, 400u) << "the extra fluid is not in the cells the knit walks";
  ASSERT_EQ(a0.size(), a1.size());
  std::size_t moved = 0;
  for (std::size_t i = 0; i < a0.size(); ++i) {
    EXPECT_TRUE(a0[i].x == a1[i].x && a0[i].y == a1[i].y && a0[i].z == a1[i].z)
        << "knit point " << i << ": the fluid out of reach changed its force";
    moved += a0[i].x != T(0) || a0[i].y != T(0) || a0[i].z != T(0);
  }
  EXPECT_GT(moved, a0.size() / 2) << "too few knit points feel the fluid to test";
}

/// One knit point and one fluid particle within reach, where the near flags taken at an anchor do
/// not see it: the anchor two knit-grid cells from the point's sorted position, the particle 0.9
/// skins from the anchor toward it, the point 2.5 skins from its sorted position toward the
/// particle (a walk of the cells would find it from where the particle is, but it is not flagged
/// near). Returns the fluid particle's velocity after its impulse (the fluid side's sum; the
/// knit side walks the fluid grid past the skin and finds the pair itself) with the lists built
/// for the anchor, and built for where the particle is.
template <typename T>
std::array<Vec3<T>, 2> unflagged_contact(exec::Backend backend) {
  const CouplingParams<T> pt = params_in<T>();
  const GridGeometry<T> geo = NeighbourGrid<T>::cover({0, 0, 0}, {0.1, 0.1, 0.1}, 1.2 * kH);
  const double cell = double(geo.cell), reach = double(coupling_reach(pt));
  const double skin = double(KnitFluidCoupling<T>(backend, KernelType::Spiky, pt, geo).skin());
  // Cells 2 and 4 along x (the grid has 7 a side), the middle of cell 3 across.
  const double y = double(geo.origin.y) + 3.5 * cell, z = double(geo.origin.z) + 3.5 * cell;
  const Vec3d sorted{double(geo.origin.x) + 3 * cell - 1e-6, y, z};
  const Vec3d anchor{double(geo.origin.x) + 4 * cell + 1e-6, y, z};
  EXPECT_GE(geo.nx, 7);
  const Vec3d knit_now = sorted + Vec3d{2.5 * skin, 0, 0};
  const Vec3d fluid_now = anchor - Vec3d{0.9 * skin, 0, 0};
  EXPECT_LT(norm(fluid_now - knit_now), reach) << "the premise: a pair within reach";
  EXPECT_GT(2.5 * skin, cell - reach - skin) << "the premise: past the anchored walk's margin";
  EXPECT_LT(2.5 * skin, cell - reach) << "the premise: within the cells' margin";
  std::array<Vec3<T>, 2> a{};
  for (int anchored = 0; anchored < 2; ++anchored) {
    Cloud c;
    c.kx = {sorted};
    c.kv = {{0, 0, 0}};
    c.km = {2e-5};
    c.handle = {kFreePoint};
    c.fx = {fluid_now};
    c.fv = {{0, 0, 0}};
    c.fm = {1e-3};
    c.frho = {1000};
    Fixture<T> fx(backend, c);
    KnitFluidCoupling<T> cp(backend, KernelType::Spiky, pt, geo);
    fx.knit.a.assign(std::vector<Vec3<T>>(1, Vec3<T>{T(0), T(0), T(0)}));
    exec::DeviceBuffer<Vec3<T>> at(backend, 0, "test.anchor");
    at.assign(std::vector<Vec3<T>>{vec_cast<T>(anchor)});
    const FluidAnchor<T> an{at.data(), 1, T(0.9 * skin)};
    cp.begin_step(fx.ex, fx.knit, fx.side(), {}, T(0), {}, anchored ? an : FluidAnchor<T>{});
    fx.knit.x.assign(std::vector<Vec3<T>>{vec_cast<T>(knit_now)});
    cp.add_forces(fx.ex, fx.knit, fx.side(), T(1));
    cp.apply_impulses(fx.ex, fx.fluid.view());
    a[anchored] = fx.fluid.v.to_host()[0];
  }
  return a;
}

} // namespace

namespace {
/// The anchored run pushes the particle as the run with lists built where it is, to `tol` of the
/// push (rounding: the two sum the same one pair).
template <typename T>
void expect_anchored_walk_finds_contact(exec::Backend backend, double tol) {
  const auto a = unflagged_contact<T>(backend);
  const double push = norm(vec_cast<double>(a[0]));
  EXPECT_GT(push, 1e-3) << "the premise: the pair pushes the particle";
  EXPECT_NEAR(norm(vec_cast<double>(a[1] - a[0])), 0.0, tol * push);
}
} // namespace

// The anchor's flags are up to a skin from where a particle is: the fluid side's walk is exact
// for a knit motion up to the cells' margin less that skin (past it, all points). Measured:
// without the slack the anchored run misses the contact (the particle's velocity stays 0).
TEST(CouplingKernels, AnchoredFlagsNarrowTheWalkCpu) {
  expect_anchored_walk_finds_contact<double>(exec::Backend::Cpu, 1e-9);
}

TEST(CouplingKernels, AnchoredFlagsNarrowTheWalkCuda) {
  if (!exec::cuda_available())
    GTEST_SKIP() << "no CUDA device";
  expect_anchored_walk_finds_contact<float>(exec::Backend::Cuda, 1e-5);
}

TEST(CouplingKernels, KnitSideIgnoresFluidOutOfReachCpu) {
  knit_side_ignores_fluid_out_of_reach<double>(exec::Backend::Cpu);
  knit_side_ignores_fluid_out_of_reach<float>(exec::Backend::Cpu);
}

TEST(CouplingKernels, MatchAllPairsReferenceCpuDouble) {
  check<double>(exec::Backend::Cpu);
}
TEST(CouplingKernels, MatchAllPairsReferenceCpuFloat) {
  check<float>(exec::Backend::Cpu);
}
TEST(CouplingKernels, MatchAllPairsReferenceCudaFloat) {
  if (!exec::cuda_available())
    GTEST_SKIP() << "no CUDA device";
  check<float>(exec::Backend::Cuda);
}
// Rows of 16: most fluid particles near the sheet have more knit points within the list's radius
// and walk their cells instead; the two kinds of rows side by side give the same forces.
TEST(CouplingKernels, OverflowingListsWalkTheirCellsCpu) {
  check<double>(exec::Backend::Cpu, Motion::None, 16);
}
TEST(CouplingKernels, OverflowingListsWalkTheirCellsCuda) {
  if (!exec::cuda_available())
    GTEST_SKIP() << "no CUDA device";
  check<float>(exec::Backend::Cuda, Motion::None, 16);
}
// The lists' rows, one a fluid particle near the knit, sized by the build before (read behind
// it): here it found the knit in a corner, few near it, and this build finds most of the fluid
// near. The rows past the room walk their cells, the knit's side walks the fluid grid (the
// transpose is marked incomplete): the same forces.
TEST(CouplingKernels, RowsPastTheRoomWalkTheirCellsCpu) {
  check<double>(exec::Backend::Cpu, Motion::None, 256, 0, Anchor::None, true);
}
TEST(CouplingKernels, RowsPastTheRoomWalkTheirCellsCuda) {
  if (!exec::cuda_available())
    GTEST_SKIP() << "no CUDA device";
  check<float>(exec::Backend::Cuda, Motion::None, 256, 0, Anchor::None, true);
}
// Knit rows of 128 fluid particles: the sheet's inner points have more within the lists' radius
// and walk the fluid grid (computing their pairs again), its edges read the pairs the fluid side
// kept; the fluid's rows all fit.
TEST(CouplingKernels, OverflowingKnitRowsWalkTheirCellsCpu) {
  check<double>(exec::Backend::Cpu, Motion::None, 256, 128);
}
TEST(CouplingKernels, OverflowingKnitRowsWalkTheirCellsCuda) {
  if (!exec::cuda_available())
    GTEST_SKIP() << "no CUDA device";
  check<float>(exec::Backend::Cuda, Motion::None, 256, 128);
}
// The knit moved within its substeps after begin_step sorted its grid: within the skin the kept
// grid and near flags find every pair; past it (no read on the host) the fluid side sees the
// watched motion and sums over all knit points.
TEST(CouplingKernels, KnitMovedWithinSkinKeepsTheGridCpu) {
  check<double>(exec::Backend::Cpu, Motion::WithinSkin);
}
TEST(CouplingKernels, KnitMovedPastListSkinWalksTheCellsCpu) {
  check<double>(exec::Backend::Cpu, Motion::PastListSkin);
}
TEST(CouplingKernels, KnitMovedPastSkinFallsBackToAllPairsCpu) {
  check<double>(exec::Backend::Cpu, Motion::PastMargin);
  check<double>(exec::Backend::Cpu, Motion::PastSkin);
}
TEST(CouplingKernels, KnitMovedFallsBackToAllPairsCuda) {
  if (!exec::cuda_available())
    GTEST_SKIP() << "no CUDA device";
  check<float>(exec::Backend::Cuda, Motion::WithinSkin);
  check<float>(exec::Backend::Cuda, Motion::PastListSkin);
  check<float>(exec::Backend::Cuda, Motion::PastSkin);
}

// The lists built for where the fluid's own lists were (an anchor within a skin of every
// particle), kept over begin_steps: the same forces as the all-pairs reference, the knit at rest,
// within its skin, past the lists' reach; and built for the fluid now once the anchor's bound
// passes the skin.
TEST(CouplingKernels, ListsKeptForAnAnchorMatchAllPairsCpu) {
  check<double>(exec::Backend::Cpu, Motion::None, 256, 0, Anchor::Kept);
  check<double>(exec::Backend::Cpu, Motion::WithinSkin, 256, 0, Anchor::Kept);
  check<double>(exec::Backend::Cpu, Motion::PastListSkin, 256, 0, Anchor::Kept);
  check<double>(exec::Backend::Cpu, Motion::PastMargin, 256, 0, Anchor::Kept);
  check<double>(exec::Backend::Cpu, Motion::None, 256, 128, Anchor::Kept);
  check<double>(exec::Backend::Cpu, Motion::WithinSkin, 256, 0, Anchor::Outrun);
}
TEST(CouplingKernels, ListsKeptForAnAnchorMatchAllPairsCuda) {
  if (!exec::cuda_available())
    GTEST_SKIP() << "no CUDA device";
  check<float>(exec::Backend::Cuda, Motion::None, 256, 0, Anchor::Kept);
  check<float>(exec::Backend::Cuda, Motion::WithinSkin, 256, 0, Anchor::Kept);
  check<float>(exec::Backend::Cuda, Motion::PastListSkin, 256, 0, Anchor::Kept);
  check<float>(exec::Backend::Cuda, Motion::None, 256, 128, Anchor::Kept);
  check<float>(exec::Backend::Cuda, Motion::WithinSkin, 256, 0, Anchor::Outrun);
}

// Eq. 11 as a hydrophilic medium needs it: draws fluid in below saturation, none at it, pushes
// out above it; decreasing throughout, so wetter knit always draws less.
TEST(CouplingKernels, LeverettJIsPositiveDryZeroSaturatedNegativeOversaturated) {
  EXPECT_NEAR(leverett_j(0.0), 1.417 - 2.120 + 1.263, 1e-15);
  EXPECT_EQ(leverett_j(1.0), 0.0);
  EXPECT_LT(leverett_j(1.2), 0.0);
  for (double s = 0; s < 1.5; s += 0.01) {
    EXPECT_LT(leverett_j(s + 0.01), leverett_j(s)) << s;
    if (s < 0.995) {
      EXPECT_GT(leverett_j(s), 0.0) << s;
    }
  }
}

// A knit point in a ring of fluid: the porosity chosen so the ring saturates it exactly (s = 1)
// gives no capillary force; a larger porosity (drier, s = 0.8) draws every particle toward the
// point, a smaller one (s = 1.25) pushes every particle away.
TEST(CouplingKernels, SaturatedKnitExertsNoCapillaryForce) {
  const exec::Exec ex{exec::Backend::Cpu};
  Cloud c;
  c.kx = {{0.05, 0.05, 0.05}};
  c.kv = {{0, 0, 0}};
  c.km = {1e-4};
  c.handle = {kFreePoint};
  for (int k = 0; k < 12; ++k) {
    const double th = 2 * std::numbers::pi * k / 12;
    c.fx.push_back({0.05 + 0.6 * kH * std::cos(th), 0.05 + 0.6 * kH * std::sin(th), 0.05});
    c.fv.push_back({0, 0, 0});
    c.fm.push_back(2e-3);
    c.frho.push_back(1000);
  }
  double rho = 0;
  const SpikyKernel<double> W(kH);
  for (const Vec3d& x : c.fx)
    rho += 2e-3 * W.W(norm(x - c.kx[0]));
  for (double target : {1.0, 0.8, 1.25}) {
    auto p = params();
    p.contact = false;
    p.gravity = {0, 0, 0};
    p.porosity = rho / (target * p.rho0);
    Fixture<double> fx(exec::Backend::Cpu, c);
    KnitFluidCoupling<double> cp(
        exec::Backend::Cpu, KernelType::Spiky, p,
        NeighbourGrid<double>::cover({0, 0, 0}, {0.1, 0.1, 0.1}, 1.2 * kH));
    cp.begin_step(ex, fx.knit, fx.side());
    EXPECT_NEAR(cp.saturation().to_host()[0], target, 1e-12);
    cp.add_forces(ex, fx.knit, fx.side(), 1.0);
    cp.apply_impulses(ex, fx.fluid.view());
    const auto x = fx.fluid.x.to_host();
    const auto v = fx.fluid.v.to_host();
    for (std::size_t q = 0; q < x.size(); ++q) {
      const double radial = dot(v[q], x[q] - c.kx[0]) / norm(x[q] - c.kx[0]);
      if (target == 1.0)
        EXPECT_LT(norm(v[q]), 1e-12) << "a force from saturated knit";
      else if (target < 1)
        EXPECT_LT(radial, -1e-3) << "dry knit does not draw fluid in";
      else
        EXPECT_GT(radial, 1e-3) << "oversaturated knit does not push fluid out";
    }
  }
}
