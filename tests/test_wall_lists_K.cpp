// The walls' lists (SphLists::walls): the walls' pass (boundary_pressure) reading each wall
// particle's listed fluid must give what walking the fluid grid gives, to the bit (the lists keep
// the walk's order), at the build and after the fluid moved by less than the skin (the grid and
// lists of the build kept, as a run keeps them), and where rows overflowed their capacity (those
// walk the cells). Dry wall particles get empty rows. CPU and GPU.
#include "kernels/exec/Backend.hpp"
#include "kernels/grid/NeighbourGrid.hpp"
#include "kernels/particles/FluidSet.hpp"
#include "kernels/sph/Sph.hpp"
#include "kernels/sph/SphLists.hpp"

#include "support/Bits.hpp"
#include "support/GridOrder.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

namespace kf {
namespace {

using test::same_bits;

template <typename T>
std::vector<std::uint32_t> counts(const ListView<T>& l, std::size_t n, exec::Backend backend) {
  std::vector<std::uint32_t> c(n);
  exec::copy_bytes(c.data(), exec::Backend::Cpu, l.count, backend, n * sizeof(std::uint32_t));
  return c;
}

template <typename T>
struct WallResult {
  std::vector<T> p, inv_rho;
  std::vector<Vec4<T>> vp;
};

template <typename T>
WallResult<T> wall_pass(const exec::Exec& ex, const SphParams<T>& prm, BoundarySet<T>& b,
                        FluidSet<T>& f, const CellView<T>& cells, const std::uint8_t* near,
                        const ListView<T>& walls) {
  // Poisoned: an element the pass leaves unwritten shows as a NaN.
  b.p.poison();
  b.vp.poison();
  b.inv_rho.poison();
  boundary_pressure(ex, prm, b.view(), f.view(), cells, static_cast<const RigidShape<T>*>(nullptr),
                    near, walls);
  return {b.p.to_host(), b.inv_rho.to_host(), b.vp.to_host()};
}

template <typename T>
void expect_same(const WallResult<T>& a, const WallResult<T>& b, const char* what) {
  EXPECT_TRUE(same_bits(a.p, b.p)) << what;
  EXPECT_TRUE(same_bits(a.inv_rho, b.inv_rho)) << what;
  EXPECT_TRUE(same_bits(a.vp, b.vp)) << what;
}

template <typename T>
void check(exec::Backend backend) {
  const double dp = 0.01, h = 2.2 * dp, s = 0.3 * h;
  const Vec3d lo{0, 0, 0}, hi{0.3, 0.2, 0.3};
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> jitter(-0.1 * dp, 0.1 * dp), u(0, 1);
  // A fluid block over part of a two-layer floor: the floor's far part stays dry.
  std::vector<Vec3<T>> xf, xb;
  for (double z = 0.5 * dp; z < 0.12; z += dp)
    for (double y = 0.5 * dp; y < hi.y; y += dp)
      for (double x = 0.5 * dp; x < 0.15; x += dp)
        xf.push_back(vec_cast<T>(Vec3d{x + jitter(rng), y + jitter(rng), z + jitter(rng)}));
  for (double z = -0.5 * dp; z > -2 * dp; z -= dp)
    for (double y = 0.5 * dp; y < hi.y; y += dp)
      for (double x = 0.5 * dp; x < hi.x; x += dp)
        xb.push_back(vec_cast<T>(Vec3d{x, y, z}));
  const std::size_t n = xf.size(), nb = xb.size();
  exec::Exec ex{backend};
  const auto geometry = NeighbourGrid<T>::cover(Vec3d{lo.x, lo.y, -0.05}, hi, h + s);
  // The walls in their own grid's order, as the solver keeps them: the fluid's rows find their
  // walls through that grid (a grid over the fluid here read b.x at the fluid's indices, past its
  // end: AddressSanitizer).
  NeighbourGrid<T> wall_grid(backend, geometry);
  xb = test::in_grid_order(wall_grid, ex, xb);
  SphParams<T> prm;
  prm.kernel = KernelType::CubicSpline;
  prm.h = T(h);
  FluidSet<T> f(backend);
  f.resize(n);
  f.x.assign(xf);
  f.m.assign(std::vector<T>(n, T(1000 * dp * dp * dp)));
  std::vector<T> rho(n);
  for (auto& r : rho)
    r = T(1000 * (1 + 0.02 * u(rng)));
  f.rho.assign(rho);
  f.drho.assign(std::vector<T>(n, T(0)));
  f.drho_prev.assign(std::vector<T>(n, T(0)));
  std::vector<Vec3<T>> v(n);
  for (auto& w : v)
    w = vec_cast<T>(Vec3d{u(rng), u(rng), u(rng)});
  f.v.assign(v);
  BoundarySet<T> b(backend);
  b.resize(nb);
  b.x.assign(xb);
  b.obstacle.assign(std::vector<std::uint32_t>(nb, kWallObstacle));
  b.volume.assign(std::vector<T>(nb, T(dp * dp * dp)));
  NeighbourGrid<T> grid(backend, geometry);
  grid.build(ex, f.x.data(), n);
  f.reorder(ex, grid.permutation());
  sph_density_predict(ex, prm, f.view(), T(0)); // p, vp, vol from rho (and xm)
  exec::DeviceBuffer<std::uint8_t> near(backend, 0, "test.near");
  grid.occupied_around(ex, near);
  const BoundaryNeighbours<T> bn{b.x.data(), b.volume.data(), nullptr,          nullptr,
                                 nullptr,    false,           wall_grid.view(), nb};
  SphLists<T> lists(backend, T(s));
  lists.build(ex, f, grid.view(), bn, T(h), near.data());
  lists.settle(ex); // the fluid rows' capacity grows here
  lists.build(ex, f, grid.view(), bn, T(h), near.data());
  lists.settle(ex);
  ASSERT_NE(lists.walls().count, nullptr);
  const WallResult<T> walk0 = wall_pass(ex, prm, b, f, grid.view(), near.data(), {});
  const WallResult<T> listed0 = wall_pass(ex, prm, b, f, grid.view(), near.data(), lists.walls());
  expect_same(walk0, listed0, "at the build");
  // Every row fits; a wet wall particle has a row, and some wall particles are dry (empty rows).
  const auto count = counts(lists.walls(), nb, backend);
  std::size_t wet = 0, dry = 0;
  for (std::size_t k = 0; k < nb; ++k) {
    EXPECT_LE(count[k], lists.walls().capacity) << k;
    if (walk0.p[k] > T(0)) {
      EXPECT_GT(count[k], 0u) << k;
    }
    (count[k] > 0 ? wet : dry) += 1;
  }
  EXPECT_GT(wet, nb / 4);
  EXPECT_GT(dry, nb / 4);
  // The walls' rows are as wide as their densest needs (the fluid did not move between the
  // builds: the width the first build read), narrower than the fluid's rows: a wall particle's
  // fluid lies on one side of it.
  const std::uint32_t densest = *std::max_element(count.begin(), count.end());
  EXPECT_EQ(lists.walls().capacity, NeighbourList<T>::settled_capacity(densest));
  EXPECT_LT(lists.walls().capacity, lists.view().capacity);
  // The fluid moves by up to 0.9 s (xm, as the predictor writes it each step); grid and lists
  // stay those of the build.
  auto x = f.x.to_host();
  for (auto& p : x) {
    Vec3d d{u(rng) - 0.5, u(rng) - 0.5, u(rng) - 0.5};
    d = d * (0.9 * s / std::sqrt(norm2(d)) * u(rng));
    p = p + vec_cast<T>(d);
  }
  f.x.assign(x);
  sph_density_predict(ex, prm, f.view(), T(0));
  const WallResult<T> walk1 = wall_pass(ex, prm, b, f, grid.view(), near.data(), {});
  const WallResult<T> listed1 = wall_pass(ex, prm, b, f, grid.view(), near.data(), lists.walls());
  expect_same(walk1, listed1, "after the fluid moved within the skin");
  // A pass that wrote every wall since the lists' build (listed0's) lets the next ones skip the
  // dry walls (dry_written): theirs hold (P_b = 0), so the values are the full pass's. Poisoned
  // first, such a pass leaves exactly the dry walls unwritten.
  const auto skipping_pass = [&] {
    boundary_pressure(ex, prm, b.view(), f.view(), grid.view(),
                      static_cast<const RigidShape<T>*>(nullptr), near.data(), lists.walls(),
                      nullptr, true);
    return WallResult<T>{b.p.to_host(), b.inv_rho.to_host(), b.vp.to_host()};
  };
  b.p.assign(listed0.p);
  b.inv_rho.assign(listed0.inv_rho);
  b.vp.assign(listed0.vp);
  expect_same(listed1, skipping_pass(), "the dry walls skipped");
  b.p.poison();
  b.vp.poison();
  b.inv_rho.poison();
  const WallResult<T> skipped = skipping_pass();
  std::size_t unwritten = 0;
  for (std::size_t k = 0; k < nb; ++k) {
    const bool nan = std::isnan(double(skipped.p[k])) && std::isnan(double(skipped.inv_rho[k])) &&
                     std::isnan(double(skipped.vp[k].w));
    EXPECT_EQ(nan, count[k] == 0) << k;
    unwritten += nan ? 1 : 0;
  }
  EXPECT_EQ(unwritten, dry);
  EXPECT_FALSE(same_bits(walk0.p, walk1.p)); // the motion changed the pressures
  // Rows of 8: most wet rows overflow and walk their cells instead.
  NeighbourList<T> small(backend);
  const FluidView<T> fv = f.view();
  small.build_for(ex, b.x.data(), nullptr, nb, fv.xm, grid.view(), T((h + s) * (h + s)), 8,
                  AnyPair{}, near.data());
  std::size_t overflowed = 0, fitted = 0;
  for (std::uint32_t c : counts(small.view(), nb, backend))
    (c > 8 ? overflowed : c > 0 ? fitted : dry) += 1;
  EXPECT_GT(overflowed, 0u);
  EXPECT_GT(fitted, 0u);
  const WallResult<T> listed2 = wall_pass(ex, prm, b, f, grid.view(), near.data(), small.view());
  expect_same(walk1, listed2, "rows of 8 (overflows walk)");
}

TEST(WallLists, EqualTheWalkCpuFloat) {
  check<float>(exec::Backend::Cpu);
}
TEST(WallLists, EqualTheWalkCpuDouble) {
  check<double>(exec::Backend::Cpu);
}
TEST(WallLists, EqualTheWalkCudaFloat) {
  if (!exec::cuda_available())
    GTEST_SKIP() << "no CUDA device";
  check<float>(exec::Backend::Cuda);
}

} // namespace
} // namespace kf
