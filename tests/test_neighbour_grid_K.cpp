// The neighbour grid returns exactly the brute-force neighbour sets, on every backend.
#include "core/Error.hpp"
#include "kernels/exec/Algorithms.hpp"
#include "kernels/grid/NeighbourGrid.hpp"
#include "kernels/grid/NeighbourList.hpp"
#include "kernels/grid/StagedRowAppender.hpp"
#include "kernels/grid/TransposedList.hpp"
#include "kernels/particles/FluidSet.hpp"
#include "kernels/sph/SphLists.hpp"
#include "kernels/sph/SphNeighbours_K.hpp"

#include "support/GridOrder.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <random>
#include <set>
#include <vector>

using namespace kf;

namespace {

// Positions: random in the box, plus points exactly on cell faces, edges and corners, on the
// domain faces and slightly outside the domain (which fall into the edge cells).
template <typename T>
std::vector<Vec3<T>> test_points(std::size_t n, double h, const Vec3d& lo, const Vec3d& hi,
                                 unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> ux(lo.x, hi.x), uy(lo.y, hi.y), uz(lo.z, hi.z);
  std::vector<Vec3<T>> x;
  for (std::size_t i = 0; i < n; ++i)
    x.push_back(vec_cast<T>(Vec3d{ux(rng), uy(rng), uz(rng)}));
  std::uniform_int_distribution<int> cell(0, static_cast<int>((hi.x - lo.x) / h));
  for (int i = 0; i < 200; ++i) // on cell borders (grid origin is lo - h, so multiples of h)
    x.push_back(vec_cast<T>(Vec3d{lo.x + h * cell(rng), lo.y + h * (cell(rng) % 3), uz(rng)}));
  for (int i = 0; i < 100; ++i) { // on and just outside the domain faces
    x.push_back(vec_cast<T>(Vec3d{lo.x, uy(rng), uz(rng)}));
    x.push_back(vec_cast<T>(Vec3d{hi.x, uy(rng), hi.z}));
    x.push_back(vec_cast<T>(Vec3d{ux(rng), lo.y - 0.3 * h, uz(rng)}));
    x.push_back(vec_cast<T>(Vec3d{ux(rng), uy(rng), hi.z + 0.9 * h}));
  }
  x.push_back(vec_cast<T>(lo));
  x.push_back(vec_cast<T>(hi));
  return x;
}

// span: cells of h / span searched span cells on each side (the fluid's solver.cell_span);
// levels: sub-cell order within the cells (solver.cell_order).
template <typename T>
void check_against_brute_force(exec::Backend backend, int span = 1, int levels = 0) {
  const double h = 0.1;
  const Vec3d lo{0, 0, 0}, hi{1.0, 0.3, 0.55};
  auto host = test_points<T>(3000, h, lo, hi, 42);
  const std::size_t n = host.size();
  NeighbourGrid<T> grid(backend, NeighbourGrid<T>::cover(lo, hi, h / span, span), span, levels);
  ASSERT_EQ(grid.order_levels(), levels);
  exec::DeviceBuffer<Vec3<T>> x(backend);
  exec::Exec ex{backend};
  // A first build with other points (more of them, elsewhere): the second build must leave none
  // of their cells behind (it clears only the cells the first one filled).
  auto other = test_points<T>(4000, h, lo, hi, 7);
  for (auto& p : other)
    p.z = static_cast<T>(0.5 * p.z);
  x.assign(other);
  grid.build(ex, x.data(), other.size());
  x.assign(host);
  grid.build(ex, x.data(), n);

  // The permutation is a permutation, and positions sorted by it are what the tables describe.
  auto perm = grid.permutation().to_host();
  ASSERT_EQ(perm.size(), n);
  std::vector<char> seen(n, 0);
  for (auto p : perm) {
    ASSERT_LT(p, n);
    ASSERT_FALSE(seen[p]);
    seen[p] = 1;
  }
  std::vector<Vec3<T>> sorted(n);
  for (std::size_t i = 0; i < n; ++i)
    sorted[i] = host[perm[i]];
  x.assign(sorted);

  // Neighbour counts per particle found through the grid, on the backend, poisoned first.
  const T h2 = static_cast<T>(h * h);
  exec::DeviceBuffer<std::uint32_t> count(backend, n), checksum(backend, n), any(backend, n);
  count.poison();
  checksum.poison();
  any.poison();
  const auto view = grid.view();
  const Vec3<T>* px = x.data();
  std::uint32_t* pc = count.data();
  std::uint32_t* ps = checksum.data();
  std::uint32_t* pa = any.data();
  exec::for_each(
      ex, n,
      [=] KF_HD(std::size_t i) {
        std::uint32_t c = 0, s = 0, candidates = 0;
        view.for_each_candidate(px[i], [&](std::uint32_t j) {
          ++candidates;
          if (norm2(px[i] - px[j]) < h2) {
            ++c;
            s += j * 2654435761u; // order-free fingerprint of the set
          }
        });
        pc[i] = c;
        ps[i] = s;
        // has_candidates agrees with the loop (2: agree and some, 1: agree and none, 0: differ).
        const bool has = view.has_candidates(px[i]);
        pa[i] = has == (candidates > 0) ? (has ? 2u : 1u) : 0u;
      },
      "test.neighbours");
  auto got_count = count.to_host();
  auto got_sum = checksum.to_host();
  auto got_any = any.to_host();
  for (std::size_t i = 0; i < n; ++i)
    ASSERT_EQ(got_any[i], 2u) << "particle " << i << " (each sees at least itself)";

  // Host side: exact sets for a sample, counts and fingerprints for all.
  for (std::size_t i = 0; i < n; ++i) {
    std::uint32_t c = 0, s = 0;
    for (std::size_t j = 0; j < n; ++j)
      if (norm2(sorted[i] - sorted[j]) < h2) {
        ++c;
        s += static_cast<std::uint32_t>(j) * 2654435761u;
      }
    ASSERT_EQ(got_count[i], c) << "particle " << i;
    ASSERT_EQ(got_sum[i], s) << "particle " << i;
  }
  for (std::size_t i = 0; i < n; i += 37) {
    std::set<std::uint32_t> brute, viagrid;
    for (std::size_t j = 0; j < n; ++j)
      if (norm2(sorted[i] - sorted[j]) < h2)
        brute.insert(static_cast<std::uint32_t>(j));
    const CellView<T> hv = view;
    if (backend == exec::Backend::Cpu) {
      std::vector<std::uint32_t> all;
      hv.for_each_candidate(sorted[i], [&](std::uint32_t j) {
        all.push_back(j);
        if (norm2(sorted[i] - sorted[j]) < h2)
          viagrid.insert(j);
      });
      EXPECT_EQ(brute, viagrid) << "particle " << i;
      // Lanes sharing the walk (for_each_lanes) visit every candidate once between them.
      for (std::uint32_t stride : {2u, 4u, 8u}) {
        std::vector<std::uint32_t> shared;
        for (std::uint32_t lane = 0; lane < stride; ++lane)
          hv.for_each_candidate(sorted[i], lane, stride,
                                [&](std::uint32_t j) { shared.push_back(j); });
        std::sort(shared.begin(), shared.end());
        std::vector<std::uint32_t> want = all;
        std::sort(want.begin(), want.end());
        EXPECT_EQ(shared, want) << "particle " << i << ", " << stride << " lanes";
      }
    }
  }
}

} // namespace

TEST(NeighbourGrid, MatchesBruteForceCpuFloat) {
  check_against_brute_force<float>(exec::Backend::Cpu);
}
TEST(NeighbourGrid, MatchesBruteForceCpuDouble) {
  check_against_brute_force<double>(exec::Backend::Cpu);
}
TEST(NeighbourGrid, MatchesBruteForceCudaFloat) {
  if (!exec::cuda_available())
    GTEST_SKIP() << "no CUDA device";
  check_against_brute_force<float>(exec::Backend::Cuda);
}
TEST(NeighbourGrid, SubCellOrderMatchesBruteForceCpu) {
  check_against_brute_force<float>(exec::Backend::Cpu, 1, 1);
  check_against_brute_force<double>(exec::Backend::Cpu, 1, 2);
  check_against_brute_force<float>(exec::Backend::Cpu, 2, 2);
}
TEST(NeighbourGrid, SubCellOrderMatchesBruteForceCuda) {
  if (!exec::cuda_available())
    GTEST_SKIP() << "no CUDA device";
  check_against_brute_force<float>(exec::Backend::Cuda, 1, 2);
}
TEST(NeighbourGrid, HalfCellsMatchBruteForceCpu) {
  check_against_brute_force<float>(exec::Backend::Cpu, 2);
  check_against_brute_force<double>(exec::Backend::Cpu, 3);
}
TEST(NeighbourGrid, HalfCellsMatchBruteForceCuda) {
  if (!exec::cuda_available())
    GTEST_SKIP() << "no CUDA device";
  check_against_brute_force<float>(exec::Backend::Cuda, 2);
}

// The lists hold exactly the brute-force neighbour sets, in the grid's candidate order, and grow
// past their first capacity (32) when a particle has more neighbours (~75 here).
template <typename T>
void check_lists(exec::Backend backend) {
  const double h = 0.1;
  const Vec3d lo{0, 0, 0}, hi{1.0, 0.3, 0.55};
  const auto host = test_points<T>(3000, h, lo, hi, 11);
  const std::size_t n = host.size();
  exec::Exec ex{backend};
  NeighbourGrid<T> grid(backend, NeighbourGrid<T>::cover(lo, hi, h));
  exec::DeviceBuffer<Vec3<T>> x(backend);
  const auto sorted = test::in_grid_order(grid, ex, host);
  x.assign(sorted);
  NeighbourList<T> lists(backend);
  const T h2 = static_cast<T>(h * h);
  exec::reset_peak_bytes(backend);
  const std::size_t before = exec::held_bytes(backend).now;
  lists.build(ex, x.data(), n, grid.view(), h2);
  EXPECT_GT(lists.most(), 32u) << "the test must make the capacity grow";
  EXPECT_GE(lists.capacity(), lists.most());
  // The build grew its lists from 32 slots a row: the first lists are freed before the wider
  // ones are taken (every row is written again), so the build's peak is the lists it keeps. The
  // CUDA backend's reductions take their scratch at first use, within this build.
  if (backend == exec::Backend::Cpu) {
    EXPECT_EQ(exec::held_bytes(backend).peak - before, lists.bytes())
        << "the build held the narrow and the wide lists at once";
  }
  // The lists, copied to the host.
  const ListView<T> v = lists.view();
  std::vector<std::uint32_t> c(n), l(std::size_t(lists.capacity()) * n);
  exec::copy_bytes(c.data(), exec::Backend::Cpu, v.count, backend, n * sizeof(std::uint32_t));
  exec::copy_bytes(l.data(), exec::Backend::Cpu, v.list, backend, l.size() * sizeof(std::uint32_t));
  const CellView<T> cells = grid.view();
  if (backend == exec::Backend::Cuda)
    return; // the cell tables are on the device; the counts were checked by the CPU case
  for (std::size_t i = 0; i < n; ++i) {
    std::vector<std::uint32_t> want;
    cells.for_each_candidate(sorted[i], [&](std::uint32_t j) {
      if (norm2(sorted[i] - sorted[j]) < h2)
        want.push_back(j);
    });
    ASSERT_EQ(c[i], want.size()) << "particle " << i;
    for (std::size_t k = 0; k < want.size(); ++k)
      ASSERT_EQ(l[v.slot(i, k)], want[k]) << "particle " << i << " slot " << k;
    std::size_t brute = 0;
    for (std::size_t j = 0; j < n; ++j)
      brute += norm2(sorted[i] - sorted[j]) < h2;
    ASSERT_EQ(c[i], brute) << "particle " << i;
  }
}

TEST(NeighbourList, MatchesTheGridInOrderCpu) {
  check_lists<float>(exec::Backend::Cpu);
  check_lists<double>(exec::Backend::Cpu);
}

TEST(NeighbourList, MatchesTheCpuListsCuda) {
  if (!exec::cuda_available())
    GTEST_SKIP() << "no CUDA device";
  // Same points, both backends: identical counts and slots (the same candidate order).
  const double h = 0.1;
  const Vec3d lo{0, 0, 0}, hi{1.0, 0.3, 0.55};
  const auto host = test_points<float>(3000, h, lo, hi, 11);
  std::vector<std::uint32_t> got[2];
  std::uint32_t cap[2];
  ListView<float> slot_of;
  int k = 0;
  for (exec::Backend b : {exec::Backend::Cpu, exec::Backend::Cuda}) {
    exec::Exec ex{b};
    NeighbourGrid<float> grid(b, NeighbourGrid<float>::cover(lo, hi, h));
    exec::DeviceBuffer<Vec3<float>> x(b);
    x.assign(host);
    grid.build(ex, x.data(), host.size());
    exec::DeviceBuffer<Vec3<float>> xs(b, host.size());
    exec::gather(ex, grid.permutation(), x, xs, "test.gather");
    NeighbourList<float> lists(b);
    lists.build(ex, xs.data(), host.size(), grid.view(), float(h * h));
    const auto v = lists.view();
    got[k].resize(host.size() * (1 + std::size_t(lists.capacity())));
    exec::copy_bytes(got[k].data(), exec::Backend::Cpu, v.count, b,
                     host.size() * sizeof(std::uint32_t));
    exec::copy_bytes(got[k].data() + host.size(), exec::Backend::Cpu, v.list, b,
                     host.size() * lists.capacity() * sizeof(std::uint32_t));
    cap[k++] = lists.capacity();
    slot_of = v; // the layout only (capacity, rows): the same on both backends
  }
  ASSERT_EQ(cap[0], cap[1]);
  const std::size_t n = host.size();
  for (std::size_t i = 0; i < n; ++i) {
    ASSERT_EQ(got[0][i], got[1][i]) << "count of particle " << i;
    for (std::uint32_t s = 0; s < got[0][i]; ++s)
      ASSERT_EQ(got[0][n + slot_of.slot(i, s)], got[1][n + slot_of.slot(i, s)])
          << "particle " << i << " slot " << s;
  }
}

// The SPH lists built by chunks of particles (SphChunkListBuilder: on the GPU a warp walks the
// union of 32 particles' cell rows; on the CPU a chunk is one particle) hold exactly the rows of
// a one-particle walk of the grids done here on the host: the same entries in the same order,
// fluid then boundary, and each row is the brute-force set within the radius. ~18 points a cell, so
// a warp's particles span several cells and often two rows of cells. Boundary points fill a floor
// slab, so rows near it mix both kinds and rows far from it skip the boundary walk. Warp false:
// the builder a thread a particle (the GPU's choice for few particles), the same rows.
template <typename T, bool Warp = true>
void check_sph_chunk_builder(exec::Backend backend, int span) {
  const double h = 0.1;
  const Vec3d lo{0, 0, 0}, hi{1.0, 0.3, 0.55};
  const auto fluid = test_points<T>(3000, h, lo, hi, 5);
  std::vector<Vec3<T>> wall;
  for (double z = -0.05; z < 0.0; z += 0.025)
    for (double y = 0.0; y <= 0.3; y += 0.025)
      for (double xx = 0.0; xx <= 1.0; xx += 0.025)
        wall.push_back(vec_cast<T>(Vec3d{xx, y, z}));
  exec::Exec ex{backend};
  // Cells of h / span searched span cells on: (2 span + 1)^2 rows a group, 49 (more than a
  // warp's lanes) with span 3.
  const auto geo = NeighbourGrid<T>::cover(lo, hi, h / span, span);
  NeighbourGrid<T> fgrid(backend, geo, span), bgrid(backend, geo, span);
  const auto xf = test::in_grid_order(fgrid, ex, fluid), xb = test::in_grid_order(bgrid, ex, wall);
  std::vector<Vec4<T>> xm_host;
  for (const auto& p : xf)
    xm_host.push_back({p.x, p.y, p.z, T(1)});
  exec::DeviceBuffer<Vec3<T>> dxb(backend);
  exec::DeviceBuffer<Vec4<T>> dxm(backend);
  dxb.assign(xb);
  dxm.assign(xm_host);
  exec::DeviceBuffer<std::uint8_t> near(backend, 0, "near");
  bgrid.occupied_around(ex, near);
  BoundaryNeighbours<T> b;
  b.x = dxb.data();
  b.cells = bgrid.view();
  b.n = xb.size();
  b.near = near.data();
  const T r2 = static_cast<T>(0.9 * h * 0.9 * h);
  const std::size_t n = xf.size();
  const CellView<T> cells = fgrid.view();
  NeighbourList<T> by_chunk(backend);
  by_chunk.template build_chunked<Warp ? 32 : 1>(
      ex, n,
      [&](const ListSink& o) {
        return SphChunkListBuilder<T, Warp>{dxm.data(), cells, b, r2, o, n};
      },
      "test.by_chunk");
  // The reference: host grids of the same geometry (the same order as the backend's, checked),
  // each particle walking its own cell rows, fluid then boundary.
  const exec::Exec host{exec::Backend::Cpu};
  NeighbourGrid<T> hf(exec::Backend::Cpu, geo, span), hb(exec::Backend::Cpu, geo, span);
  {
    exec::DeviceBuffer<Vec3<T>> xs(exec::Backend::Cpu);
    xs.assign(fluid);
    hf.build(host, xs.data(), fluid.size());
    xs.assign(wall);
    hb.build(host, xs.data(), wall.size());
  }
  ASSERT_EQ(hf.permutation().to_host(), fgrid.permutation().to_host());
  ASSERT_EQ(hb.permutation().to_host(), bgrid.permutation().to_host());
  auto walk = [&](std::size_t i) {
    std::vector<std::uint32_t> r;
    hf.view().for_each_row_range(xf[i], [&](std::uint32_t a, std::uint32_t e) {
      for (std::uint32_t j = a; j < e; ++j)
        if (norm2(xf[i] - xf[j]) < r2)
          r.push_back(j);
    });
    hb.view().for_each_row_range(xf[i], [&](std::uint32_t a, std::uint32_t e) {
      for (std::uint32_t k = a; k < e; ++k)
        if (norm2(xf[i] - xb[k]) < r2)
          r.push_back(k | kBoundaryEntry);
    });
    return r;
  };
  auto rows = [&](const NeighbourList<T>& l) {
    const ListView<T> v = l.view();
    std::vector<std::uint32_t> c(n), s(std::size_t(l.capacity()) * n);
    exec::copy_bytes(c.data(), exec::Backend::Cpu, v.count, backend, n * sizeof(std::uint32_t));
    exec::copy_bytes(s.data(), exec::Backend::Cpu, v.list, backend,
                     s.size() * sizeof(std::uint32_t));
    std::vector<std::vector<std::uint32_t>> r(n);
    for (std::size_t i = 0; i < n; ++i)
      for (std::uint32_t k = 0; k < c[i] && k < l.capacity(); ++k)
        r[i].push_back(s[v.slot(i, k)]);
    return std::pair{c, r};
  };
  const auto [cc, rc] = rows(by_chunk);
  std::size_t mixed = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const auto one = walk(i);
    ASSERT_EQ(cc[i], one.size()) << "count of particle " << i;
    ASSERT_EQ(rc[i], one) << "row of particle " << i;
    std::vector<std::uint32_t> want;
    for (std::uint32_t j = 0; j < n; ++j)
      if (norm2(xf[i] - xf[j]) < r2)
        want.push_back(j);
    for (std::uint32_t k = 0; k < xb.size(); ++k)
      if (norm2(xf[i] - xb[k]) < r2)
        want.push_back(k | kBoundaryEntry);
    auto got = rc[i];
    std::sort(got.begin(), got.end());
    std::sort(want.begin(), want.end());
    ASSERT_EQ(got, want) << "particle " << i;
    mixed += !want.empty() && (want.back() & kBoundaryEntry) && !(want.front() & kBoundaryEntry);
  }
  EXPECT_GT(mixed, 100u) << "rows must mix fluid and boundary entries";
  EXPECT_GT(by_chunk.most(), 32u) << "the capacity must grow";
}

/// SphLists::stale_after's local rule (SphLists.hpp). Its bound must equal a brute-force union
/// of the displacement boxes of the cells within 2 of each cell, over the whole grid; a smooth
/// displacement field that the global rules reject (2 max |d| and the box diagonal over s) must
/// keep the lists, which must still hold every pair within h; a slip plane (relative
/// displacement 1.8 s) and a translation past s (the grid's walks) must rebuild; a shear at the
/// edge of the filled cells (the pass runs over their box only) must be found.
template <typename T>
void check_local_rule(exec::Backend backend) {
  const double h = 0.1, s = 0.02, dp = 0.03;
  const Vec3d lo{0, 0, 0}, hi{2.0, 0.3, 0.3};
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> jitter(-0.2 * dp, 0.2 * dp);
  std::vector<Vec3<T>> pts;
  for (double z = 0.5 * dp; z < hi.z; z += dp)
    for (double y = 0.5 * dp; y < hi.y; y += dp)
      for (double xx = 0.5 * dp; xx < hi.x; xx += dp)
        pts.push_back(vec_cast<T>(Vec3d{xx + jitter(rng), y + jitter(rng), z + jitter(rng)}));
  const std::size_t n = pts.size();
  exec::Exec ex{backend};
  FluidSet<T> f(backend);
  f.resize(n);
  f.x.assign(pts);
  f.m.assign(std::vector<T>(n, T(1)));
  // The grid reaches past the particles on every side (as the pour's domain past its fluid):
  // the pass runs over the box of the filled cells only, and must find the whole grid's bound.
  NeighbourGrid<T> grid(backend, NeighbourGrid<T>::cover(lo - Vec3d{0.5, 0.3, 0.3},
                                                         hi + Vec3d{0.6, 0.4, 0.5}, h + s));
  grid.build(ex, f.x.data(), n);
  f.reorder(ex, grid.permutation());
  SphLists<T> lists(backend, T(s));
  lists.build(ex, f, grid.view(), BoundaryNeighbours<T>{}, T(h));
  // The first build waits for its rows to fit (rows of more than the first capacity: built
  // again inside); a later one is read back behind it, and read before settle() it throws.
  EXPECT_NO_THROW(lists.view());
  EXPECT_GT(lists.capacity(), 32u);
  lists.build(ex, f, grid.view(), BoundaryNeighbours<T>{}, T(h));
  EXPECT_THROW(lists.view(), Error); // not settled yet
  lists.settle(ex);
  const std::vector<Vec3<T>> x0 = f.x.to_host();
  const GridGeometry<T> geo = grid.geometry();
  auto move = [&](auto&& d) {
    std::vector<Vec3<T>> x(n);
    for (std::size_t i = 0; i < n; ++i)
      x[i] = x0[i] + vec_cast<T>(d(vec_cast<double>(x0[i])));
    f.x.assign(x);
    return x;
  };
  // The reference: per cell (of the listed positions) the box of d, then over each cell's
  // 3^3 neighbourhood (the pair's midpoint cell's) the union's diagonal, the largest over the
  // cells.
  auto local_reference = [&](const std::vector<Vec3<T>>& x) {
    const double big = std::numeric_limits<double>::max();
    std::vector<Vec3d> blo(geo.cells(), Vec3d{big, big, big}),
        bhi(geo.cells(), Vec3d{-big, -big, -big});
    for (std::size_t i = 0; i < n; ++i) {
      int cx, cy, cz;
      geo.coords(x0[i], cx, cy, cz);
      const Vec3d d = vec_cast<double>(Vec3<T>(x[i] - x0[i]));
      const std::uint32_t c = geo.linear(cx, cy, cz);
      blo[c] = {std::min(blo[c].x, d.x), std::min(blo[c].y, d.y), std::min(blo[c].z, d.z)};
      bhi[c] = {std::max(bhi[c].x, d.x), std::max(bhi[c].y, d.y), std::max(bhi[c].z, d.z)};
    }
    double worst = 0;
    for (int z = 0; z < geo.nz; ++z)
      for (int y = 0; y < geo.ny; ++y)
        for (int xx = 0; xx < geo.nx; ++xx) {
          Vec3d ulo{big, big, big}, uhi{-big, -big, -big};
          for (int c = std::max(z - 1, 0); c <= std::min(z + 1, geo.nz - 1); ++c)
            for (int b = std::max(y - 1, 0); b <= std::min(y + 1, geo.ny - 1); ++b)
              for (int a = std::max(xx - 1, 0); a <= std::min(xx + 1, geo.nx - 1); ++a) {
                const std::uint32_t k = geo.linear(a, b, c);
                ulo = {std::min(ulo.x, blo[k].x), std::min(ulo.y, blo[k].y),
                       std::min(ulo.z, blo[k].z)};
                uhi = {std::max(uhi.x, bhi[k].x), std::max(uhi.y, bhi[k].y),
                       std::max(uhi.z, bhi[k].z)};
              }
          const double ex2 = std::max(uhi.x - ulo.x, 0.0), ey = std::max(uhi.y - ulo.y, 0.0),
                       ez = std::max(uhi.z - ulo.z, 0.0);
          worst = std::max(worst, std::sqrt(ex2 * ex2 + ey * ey + ez * ez));
        }
    return worst;
  };
  const T inf = std::numeric_limits<T>::infinity();
  const double tol = 1e-5 * s;

  // 1. d_x from +0.95 s to -0.95 s along the 2 m: globally 1.9 s apart, locally ~0.35 s (the
  // 3 cells of 0.12 m around a midpoint cell; 0.57 s over the 5 cells of the rule before).
  // The local pass's boxes of displacements: none before it first runs, then one pair a cell
  // of the box of cells the build filled, widened by the reach (the span) and clipped to the
  // grid, which the test's grid exceeds (its margin): not a box for every cell of the grid.
  const std::size_t before_local = lists.bytes();
  std::size_t region_cells = 1;
  {
    int lo[3] = {geo.nx, geo.ny, geo.nz}, hi[3] = {-1, -1, -1};
    const int dims[3] = {geo.nx, geo.ny, geo.nz}, reach = grid.view().span;
    for (const auto& p : x0) {
      int c[3];
      geo.coords(p, c[0], c[1], c[2]);
      for (int a = 0; a < 3; ++a) {
        lo[a] = std::min(lo[a], c[a]);
        hi[a] = std::max(hi[a], c[a]);
      }
    }
    for (int a = 0; a < 3; ++a)
      region_cells *=
          std::size_t(std::min(hi[a] + reach, dims[a] - 1) - std::max(lo[a] - reach, 0) + 1);
  }
  ASSERT_LT(region_cells, std::size_t(geo.cells()));
  auto x = move([&](const Vec3d& p) { return Vec3d{s * (0.95 - 0.95 * p.x), 0, 0}; });
  EXPECT_FALSE(lists.stale_after(ex, f, inf, false)) << "the smooth field must keep the lists";
  EXPECT_EQ(lists.bytes() - before_local, 2 * sizeof(typename SphLists<T>::Box) * region_cells);
  const double local = local_reference(x);
  EXPECT_NEAR(lists.last_local(), local, tol);
  EXPECT_LT(local, 0.45 * s);
  EXPECT_GT(local, 0.25 * s);
  EXPECT_GT(2 * lists.last_largest(), 1.8 * s) << "the global rules alone would rebuild";
  EXPECT_NEAR(lists.last_pair_bound(), local, tol);
  if (backend == exec::Backend::Cpu) { // the lists' arrays are host memory
    const ListView<T> v = lists.view();
    std::size_t pairs = 0;
    for (std::size_t i = 0; i < n; ++i) {
      std::set<std::uint32_t> listed;
      ASSERT_TRUE(v.complete(i));
      for (std::uint32_t k = 0; k < v.count[i]; ++k)
        listed.insert(v.list[v.slot(i, k)]);
      for (std::size_t j = 0; j < n; ++j)
        if (j != i && double(norm2(x[i] - x[j])) < h * h) {
          ++pairs;
          ASSERT_TRUE(listed.count(static_cast<std::uint32_t>(j))) << i << " misses " << j;
        }
    }
    EXPECT_GT(pairs, 20 * n) << "too few pairs to mean anything";
  }

  // 2. A slip plane at z = 0.15: |d| = 0.9 s on both sides, 1.8 s apart across it.
  x = move([&](const Vec3d& p) { return Vec3d{p.z < 0.15 ? -0.9 * s : 0.9 * s, 0, 0}; });
  EXPECT_TRUE(lists.stale_after(ex, f, inf, false)) << "the slip plane must rebuild";
  EXPECT_NEAR(lists.last_local(), local_reference(x), tol);
  EXPECT_NEAR(lists.last_local(), 1.8 * s, tol);

  // 3. Everything translated by 1.5 s: no pair closes in, but the grid's walks need |d| <= s.
  x = move([&](const Vec3d&) { return Vec3d{0, 1.5 * s, 0}; });
  EXPECT_TRUE(lists.stale_after(ex, f, inf, false)) << "a translation past s must rebuild";
  EXPECT_NEAR(lists.last_largest(), 1.5 * s, tol);
  EXPECT_TRUE(std::isinf(lists.last_local())) << "the global reading decided: no local pass";

  // 4. Translated by 0.8 s: the box diagonal keeps the lists without the local pass.
  x = move([&](const Vec3d&) { return Vec3d{0.8 * s, 0, 0}; });
  EXPECT_FALSE(lists.stale_after(ex, f, inf, false)) << "a translation within s keeps the lists";
  EXPECT_NEAR(lists.last_pair_bound(), 0.8 * s, tol);
  EXPECT_TRUE(std::isinf(lists.last_local()));

  // 5. The largest local shear at the filled box's edge (the first 0.06 m moved 0.9 s along x,
  // the last 0.1 m back 0.3 s): the pass must reach the box's first cells.
  x = move([&](const Vec3d& p) {
    return Vec3d{p.x < 0.06 ? 0.9 * s : p.x > 1.9 ? -0.3 * s : 0.0, 0, 0};
  });
  EXPECT_FALSE(lists.stale_after(ex, f, inf, false));
  EXPECT_NEAR(lists.last_local(), local_reference(x), tol);
  EXPECT_NEAR(lists.last_local(), 0.9 * s, tol);
}

// The staged appender against the plain one (RowAppender, entry by entry): random hit masks
// over 32-candidate blocks, pushed 16 bits at a time with a flush after each, as the chunk
// builder does; rows that fit, rows that overflow their capacity, empty rows. The rows are
// poisoned first; the last group's slots past the count must hold kNoEntry, in both.
// build_for with eight lanes a query point writes the rows the one-lane build writes, slot for
// slot: the same candidates in the same order, the same counts past a row's capacity (an
// overflow its user must see), nothing for an inactive query point, the last group padded. Query
// points elsewhere than the candidates (a fluid over a knit), ~40 candidates in range each against
// a capacity of 24.
template <typename T>
void check_lane_build_for(exec::Backend backend) {
  const double h = 0.1;
  const Vec3d lo{0, 0, 0}, hi{1.0, 0.3, 0.55};
  const auto cand = test_points<T>(3000, h, lo, hi, 5);
  const auto query = test_points<T>(1500, h, lo, hi, 6);
  std::vector<std::uint32_t> active(query.size());
  for (std::size_t i = 0; i < active.size(); ++i)
    active[i] = i % 3 != 0;
  const T r2 = static_cast<T>(0.07 * 0.07);
  const std::uint32_t capacity = 24;
  std::vector<std::uint32_t> rows[2];
  std::size_t slots = 0;
  for (int lanes : {1, 8}) {
    const exec::Backend b = lanes == 1 ? exec::Backend::Cpu : backend;
    exec::Exec ex{b};
    NeighbourGrid<T> grid(b, NeighbourGrid<T>::cover(lo, hi, h));
    exec::DeviceBuffer<Vec3<T>> x(b), xs(b, cand.size()), q(b);
    exec::DeviceBuffer<std::uint32_t> on(b);
    x.assign(cand);
    q.assign(query);
    on.assign(active);
    grid.build(ex, x.data(), cand.size());
    exec::gather(ex, grid.permutation(), x, xs, "test.gather");
    NeighbourList<T> lists(b);
    if (lanes == 1)
      lists.build_for(ex, q.data(), on.data(), query.size(), xs.data(), grid.view(), r2, capacity);
    else
      lists.template build_for<8>(ex, q.data(), on.data(), query.size(), xs.data(), grid.view(), r2,
                                  capacity);
    const auto v = lists.view();
    slots = v.capacity;
    auto& got = rows[lanes == 8];
    got.assign(query.size() * (1 + slots), 0xDEADBEEFu);
    exec::copy_bytes(got.data(), exec::Backend::Cpu, v.count, b,
                     query.size() * sizeof(std::uint32_t));
    exec::copy_bytes(got.data() + query.size(), exec::Backend::Cpu, v.list, b,
                     query.size() * slots * sizeof(std::uint32_t));
  }
  const std::size_t n = query.size();
  const ListView<T> layout{nullptr, nullptr, slots, n};
  std::size_t overflowing = 0, listed = 0;
  for (std::size_t i = 0; i < n; ++i) {
    ASSERT_EQ(rows[1][i], rows[0][i]) << "count of query point " << i;
    if (!active[i]) {
      ASSERT_EQ(rows[1][i], 0u) << "inactive query point " << i;
    }
    overflowing += rows[0][i] > slots;
    listed += rows[0][i];
    const std::size_t m = std::min<std::size_t>(rows[0][i], slots);
    for (std::size_t k = 0; k < m; ++k)
      ASSERT_EQ(rows[1][n + layout.slot(i, k)], rows[0][n + layout.slot(i, k)])
          << "query point " << i << " slot " << k;
    // The last group's rest: kNoEntry in both (the GPU's readers load whole groups).
    for (std::size_t k = m; k % kListGroup != 0; ++k)
      for (int l : {0, 1})
        ASSERT_EQ(rows[l][n + layout.slot(i, k)], kNoEntry)
            << (l ? "eight lanes" : "one lane") << ", query point " << i << " slot " << k;
  }
  EXPECT_GT(overflowing, n / 10) << "the test must overflow some rows";
  EXPECT_GT(listed, 10 * n) << "too few neighbours to test";
}

TEST(NeighbourList, BuildForInLanesWritesTheOneLaneRowsCpu) {
  check_lane_build_for<float>(exec::Backend::Cpu);
}

TEST(NeighbourList, BuildForInLanesWritesTheOneLaneRowsCuda) {
  if (!exec::cuda_available())
    GTEST_SKIP() << "no CUDA device";
  check_lane_build_for<float>(exec::Backend::Cuda);
  check_lane_build_for<double>(exec::Backend::Cuda);
}

// The transpose against a host one: random source rows (some inactive, some over their capacity)
// of entries mapped through a permutation to targets; some targets meet more sources than their
// capacity. Each target row must hold exactly the slots of the active source rows listing it,
// in ascending order of row, on every backend and thread count; a source row past its capacity
// must flag the transpose.
// The buffers are filled first by a dense transpose of other rows, so that a slot the second
// build does not write shows as a stale entry.
namespace {

struct TransposeCase {
  std::size_t sources = 0, targets = 0;
  std::uint32_t src_capacity = 0, capacity = 0;
  std::vector<std::uint32_t> count, list, active, map; // source rows in ListView's layout
};

TransposeCase transpose_case(unsigned seed, std::size_t sources, std::size_t targets,
                             std::uint32_t src_capacity, std::uint32_t capacity,
                             bool overflow_source) {
  std::mt19937 rng(seed);
  TransposeCase c{sources, targets, src_capacity, capacity, {}, {}, {}, {}};
  c.count.assign(sources, 0);
  c.list.assign(sources * src_capacity, 0xDEADBEEFu);
  c.active.resize(sources);
  c.map.resize(targets);
  std::iota(c.map.begin(), c.map.end(), 0u);
  std::shuffle(c.map.begin(), c.map.end(), rng);
  const ListView<float> layout{nullptr, nullptr, src_capacity, sources};
  for (std::size_t j = 0; j < sources; ++j) {
    c.active[j] = rng() % 5 != 0;
    // Distinct entries, clustered so that some targets meet many sources.
    std::set<std::uint32_t> row;
    const std::uint32_t want = rng() % (src_capacity + 1);
    // A tenth of the rows near target 0: there the rows overflow, elsewhere ~27 a row.
    const std::uint32_t base =
        static_cast<std::uint32_t>(rng() % 10 == 0 ? rng() % 16 : rng() % targets);
    while (row.size() < want)
      row.insert(static_cast<std::uint32_t>((base + rng() % 64) % targets));
    std::uint32_t k = 0;
    for (std::uint32_t e : row)
      c.list[layout.slot(j, k++)] = e;
    c.count[j] = want;
  }
  if (overflow_source) // an active row that counted more than it could hold
    for (std::size_t j = 0; j < sources; ++j)
      if (c.active[j] && c.count[j] > 0) {
        c.count[j] = src_capacity + 3;
        break;
      }
  return c;
}

struct TransposeResult {
  std::vector<std::uint32_t> count, list;
  std::uint32_t incomplete = 0;
  std::size_t capacity = 0;
};

TransposeResult run_transpose(exec::Backend b, TransposedList<float>& tl, const TransposeCase& c) {
  exec::Exec ex{b};
  exec::DeviceBuffer<std::uint32_t> count(b), list(b), active(b), map(b);
  count.assign(c.count);
  list.assign(c.list);
  active.assign(c.active);
  map.assign(c.map);
  tl.build(ex, ListView<float>{count.data(), list.data(), c.src_capacity, c.sources}, active.data(),
           map.data(), c.targets, c.capacity);
  const ListView<float> v = tl.view();
  TransposeResult r;
  r.capacity = v.capacity;
  r.count.resize(c.targets);
  r.list.resize(c.targets * v.capacity);
  exec::copy_bytes(r.count.data(), exec::Backend::Cpu, v.count, b,
                   c.targets * sizeof(std::uint32_t));
  exec::copy_bytes(r.list.data(), exec::Backend::Cpu, v.list, b, r.list.size() * 4);
  exec::copy_bytes(&r.incomplete, exec::Backend::Cpu, tl.incomplete(), b, 4);
  return r;
}

void check_transpose(exec::Backend b) {
  for (const bool overflow_source : {false, true}) {
    const TransposeCase c = transpose_case(11, 1200, 700, 40, 48, overflow_source);
    // Every target met by every source of a dense case first: all slots written.
    TransposeCase dense = transpose_case(12, 3000, 700, 40, 48, false);
    TransposedList<float> tl(b);
    run_transpose(b, tl, dense);
    const TransposeResult got = run_transpose(b, tl, c);
    // The host's transpose.
    std::vector<std::vector<std::uint32_t>> want(c.targets);
    const ListView<float> layout{nullptr, nullptr, c.src_capacity, c.sources};
    bool flagged = false;
    for (std::size_t j = 0; j < c.sources; ++j) {
      if (!c.active[j])
        continue;
      if (c.count[j] > c.src_capacity) {
        flagged = true;
        continue;
      }
      for (std::uint32_t k = 0; k < c.count[j]; ++k)
        want[c.map[c.list[layout.slot(j, k)]]].push_back(
            static_cast<std::uint32_t>(layout.slot(j, k)));
    }
    EXPECT_EQ(got.incomplete != 0, flagged);
    EXPECT_EQ(got.capacity, 48u);
    const ListView<float> out{nullptr, nullptr, got.capacity, c.targets};
    std::size_t full = 0, over = 0, pairs = 0;
    for (std::size_t t = 0; t < c.targets; ++t) {
      ASSERT_EQ(got.count[t], want[t].size()) << "target " << t;
      pairs += want[t].size();
      if (want[t].size() > got.capacity) {
        ++over;
        continue;
      }
      full += want[t].size() > got.capacity / 2;
      for (std::size_t k = 0; k < want[t].size(); ++k) // rows ascending by construction
        ASSERT_EQ(got.list[out.slot(t, k)], want[t][k]) << "target " << t << " slot " << k;
    }
    // The case must test something (measured: 375 rows over half full, 33 over, 19.1k pairs).
    EXPECT_GT(full, 300u);
    EXPECT_GT(over, 20u);
    EXPECT_GT(pairs, 15000u);
  }
}

} // namespace

TEST(TransposedList, RowsAreTheHostTransposeAscendingCpu) {
  check_transpose(exec::Backend::Cpu);
}

TEST(TransposedList, RowsAreTheHostTransposeAscendingCuda) {
  if (!exec::cuda_available())
    GTEST_SKIP() << "no CUDA device";
  check_transpose(exec::Backend::Cuda);
}

TEST(StagedRowAppender, MatchesEntryByEntryAppends) {
  constexpr std::uint32_t kPoison = 0xDEADBEEFu;
  std::mt19937 rng(7);
  for (const std::uint32_t capacity : {8u, 40u, 96u}) {
    for (int trial = 0; trial < 200; ++trial) {
      const int blocks = static_cast<int>(rng() % 9);
      const double density = (rng() % 100) / 100.0; // from empty blocks to full ones
      std::vector<std::uint32_t> base(blocks), hits(blocks);
      for (int b = 0; b < blocks; ++b) {
        base[b] = static_cast<std::uint32_t>(rng() % 100000) | (rng() % 2 ? kBoundaryEntry : 0u);
        for (int t = 0; t < 32; ++t)
          hits[b] |= (std::uniform_real_distribution<double>(0, 1)(rng) < density ? 1u : 0u) << t;
      }
      const std::size_t rows = 3, i = 1; // a row between others: slot() strides over rows
      std::vector<std::uint32_t> count_ref(rows, kPoison), list_ref(rows * capacity, kPoison);
      std::vector<std::uint32_t> count(rows, kPoison), list(rows * capacity, kPoison);
      RowAppender ref({count_ref.data(), list_ref.data(), capacity, rows}, i);
      std::uint32_t ring[kStageSlots];
      StagedRowAppender<1> staged({count.data(), list.data(), capacity, rows}, i, ring);
      std::vector<std::uint32_t> expected;
      for (int b = 0; b < blocks; ++b) {
        for (int t = 0; t < 32; ++t)
          if (hits[b] >> t & 1u) {
            ref.push(base[b] + t);
            expected.push_back(base[b] + t);
          }
        staged.push_bits(base[b], hits[b] & 0xFFFFu);
        staged.flush();
        staged.push_bits(base[b] + 16, hits[b] >> 16);
        staged.flush();
      }
      ref.finish();
      staged.finish();
      const ListView<float> view{count.data(), list.data(), capacity, rows};
      ASSERT_EQ(count[i], expected.size());
      EXPECT_EQ(count[i], count_ref[i]);
      const std::size_t stored = std::min<std::size_t>(expected.size(), capacity);
      for (std::size_t k = 0; k < stored; ++k)
        ASSERT_EQ(list[view.slot(i, k)], expected[k]) << "capacity " << capacity << " slot " << k;
      // The last written group is padded; groups past it and other rows stay untouched.
      const std::size_t padded = (stored + kListGroup - 1) / kListGroup * kListGroup;
      for (std::size_t k = stored; k < padded; ++k) {
        EXPECT_EQ(list[view.slot(i, k)], kNoEntry) << "slot " << k;
        EXPECT_EQ(list_ref[view.slot(i, k)], kNoEntry) << "RowAppender, slot " << k;
      }
      for (std::size_t k = padded; k < capacity; ++k) {
        EXPECT_EQ(list[view.slot(i, k)], kPoison) << "slot " << k;
        EXPECT_EQ(list_ref[view.slot(i, k)], kPoison) << "RowAppender, slot " << k;
      }
      for (std::size_t r : {std::size_t(0), std::size_t(2)}) {
        EXPECT_EQ(count[r], kPoison);
        for (std::size_t k = 0; k < capacity; ++k)
          EXPECT_EQ(list[view.slot(r, k)], kPoison);
      }
    }
  }
}

TEST(SphLists, LocalRuleCpu) {
  check_local_rule<float>(exec::Backend::Cpu);
  check_local_rule<double>(exec::Backend::Cpu);
}

TEST(SphLists, LocalRuleCuda) {
  if (!exec::cuda_available())
    GTEST_SKIP() << "no CUDA device";
  check_local_rule<float>(exec::Backend::Cuda);
  check_local_rule<double>(exec::Backend::Cuda);
}

TEST(SphLists, ChunkBuilderEqualsOneParticleWalkCpu) {
  for (int span = 1; span <= 3; ++span) {
    SCOPED_TRACE("cell_span " + std::to_string(span));
    check_sph_chunk_builder<float>(exec::Backend::Cpu, span);
    check_sph_chunk_builder<double>(exec::Backend::Cpu, span);
  }
}

// Groups of lanes walk the union of their rows; with cells of h / span, (2 span + 1)^2 rows.
TEST(SphLists, ChunkBuilderEqualsOneParticleWalkCuda) {
  if (!exec::cuda_available())
    GTEST_SKIP() << "no CUDA device";
  for (int span = 1; span <= 3; ++span) {
    SCOPED_TRACE("cell_span " + std::to_string(span));
    check_sph_chunk_builder<float>(exec::Backend::Cuda, span);
    check_sph_chunk_builder<double>(exec::Backend::Cuda, span);
    check_sph_chunk_builder<float, false>(exec::Backend::Cuda, span);
  }
}

TEST(NeighbourGrid, OccupiedAroundFlagsExactlyTheCellsWithCandidates) {
  // A few particles in a large grid; flag[c] must be 1 exactly when a particle lies within span
  // cells of c along every axis (brute force over the particles' cells).
  for (int span : {1, 2}) {
    const Vec3d lo{0, 0, 0}, hi{1.0, 0.6, 0.4};
    const double cell = 0.05;
    const auto geo = NeighbourGrid<double>::cover(lo, hi, cell, span);
    NeighbourGrid<double> grid(exec::Backend::Cpu, geo, span);
    const std::vector<Vec3<double>> pts{{0.02, 0.02, 0.02}, {0.51, 0.33, 0.2}, {0.98, 0.59, 0.39}};
    exec::DeviceBuffer<Vec3<double>> x(exec::Backend::Cpu);
    x.assign(pts);
    exec::Exec ex{exec::Backend::Cpu};
    grid.build(ex, x.data(), pts.size());
    exec::DeviceBuffer<std::uint8_t> flag(exec::Backend::Cpu, 0, "flag");
    flag.poison();
    grid.occupied_around(ex, flag);
    ASSERT_EQ(flag.size(), geo.cells());
    const auto f = flag.to_host();
    std::size_t ones = 0;
    for (int z = 0; z < geo.nz; ++z)
      for (int y = 0; y < geo.ny; ++y)
        for (int xx = 0; xx < geo.nx; ++xx) {
          bool want = false;
          for (const auto& p : pts) {
            int px, py, pz;
            geo.coords(p, px, py, pz);
            want = want || (std::abs(px - xx) <= span && std::abs(py - y) <= span &&
                            std::abs(pz - z) <= span);
          }
          const std::uint8_t got = f[geo.linear(xx, y, z)];
          ASSERT_EQ(got, want ? 1 : 0) << "cell " << xx << " " << y << " " << z;
          ones += got;
        }
    const std::size_t side = 2 * span + 1;
    EXPECT_LE(ones, 3 * side * side * side);
    EXPECT_GT(ones, 0u);
  }
}

// A rank's grid is a window of the whole grid (NeighbourGrid::within): the points inside it
// must get the cells and sub-cells they get on the whole grid, go in the order the whole grid
// sorts them, and a walk from any point (outside the window too) must meet every point within
// the reach that the whole grid's walk meets, in the same order (the split's sums are one
// rank's). Reference: the whole grid over the same points.
template <typename T>
void check_window_is_the_whole_grid(int span, int levels) {
  const double h = 0.1;
  const Vec3d lo{0, 0, 0}, hi{1.2, 0.9, 0.7};
  const auto whole = NeighbourGrid<T>::cover(lo, hi, h / span, span);
  const auto geo =
      NeighbourGrid<T>::within(whole, {5, 2, 3}, {whole.nx - 4, whole.ny + 7, whole.nz - 2});
  ASSERT_EQ(geo.ox, 5);
  ASSERT_EQ(geo.nx, whole.nx - 4 - 5 + 1);
  ASSERT_EQ(geo.ny, whole.ny - 2); // clamped to the whole grid
  ASSERT_LT(geo.cells(), whole.cells());
  // The window's points: those whose cell on the whole grid lies inside it.
  std::vector<Vec3<T>> all = test_points<T>(3000, h, lo, hi, 5), inside;
  for (const auto& p : all) {
    int cx, cy, cz;
    whole.coords(p, cx, cy, cz);
    if (cx >= geo.ox && cx < geo.ox + geo.nx && cy >= geo.oy && cy < geo.oy + geo.ny &&
        cz >= geo.oz && cz < geo.oz + geo.nz)
      inside.push_back(p);
  }
  ASSERT_GT(inside.size(), 500u);
  ASSERT_LT(inside.size(), all.size());
  for (const auto& p : inside) {
    int wx, wy, wz, cx, cy, cz;
    whole.coords(p, wx, wy, wz);
    geo.coords(p, cx, cy, cz);
    ASSERT_EQ(cx + geo.ox, wx);
    ASSERT_EQ(cy + geo.oy, wy);
    ASSERT_EQ(cz + geo.oz, wz);
    ASSERT_EQ(geo.sub_cell_code(p, cx, cy, cz, levels), whole.sub_cell_code(p, wx, wy, wz, levels));
  }
  const exec::Exec ex{exec::Backend::Cpu};
  exec::DeviceBuffer<Vec3<T>> x(exec::Backend::Cpu);
  x.assign(inside);
  NeighbourGrid<T> big(exec::Backend::Cpu, whole, span, levels),
      win(exec::Backend::Cpu, geo, span, levels);
  big.build(ex, x.data(), inside.size());
  win.build(ex, x.data(), inside.size());
  ASSERT_EQ(big.order_levels(), win.order_levels());
  EXPECT_EQ(big.permutation().to_host(), win.permutation().to_host()); // one order
  // Walks from every point of the test set, inside the window or not.
  const auto pb = big.permutation().to_host(), pw = win.permutation().to_host();
  const T r2 = T(h * h);
  std::size_t met = 0;
  for (const auto& q : all) {
    std::vector<std::uint32_t> a, b;
    big.view().for_each_candidate(q, [&](std::uint32_t j) {
      if (norm2(inside[pb[j]] - q) <= r2)
        a.push_back(pb[j]);
    });
    win.view().for_each_candidate(q, [&](std::uint32_t j) {
      if (norm2(inside[pw[j]] - q) <= r2)
        b.push_back(pw[j]);
    });
    ASSERT_EQ(a, b);
    met += a.size();
  }
  EXPECT_GT(met, all.size()); // the walks met points (not a vacuous comparison)
}

TEST(NeighbourGrid, AWindowSortsAndWalksAsTheWholeGrid) {
  for (int span : {1, 2})
    for (int levels : {0, 2}) {
      SCOPED_TRACE("span " + std::to_string(span) + ", levels " + std::to_string(levels));
      check_window_is_the_whole_grid<float>(span, levels);
      check_window_is_the_whole_grid<double>(span, levels);
    }
}

TEST(NeighbourGrid, CellsAlongXHaveConsecutiveRanks) {
  // The neighbour loop reads a row of cells along x as one range of particles; that needs
  // rank(x + 1, y, z) = rank(x, y, z) + 1, and the ranks a permutation of the cells.
  const auto geo = NeighbourGrid<double>::cover({0, 0, 0}, {0.7, 0.5, 0.3}, 0.05);
  NeighbourGrid<double> grid(exec::Backend::Cpu, geo);
  const auto v = grid.view();
  std::vector<char> used(geo.cells(), 0);
  for (int z = 0; z < geo.nz; ++z)
    for (int y = 0; y < geo.ny; ++y)
      for (int x = 0; x < geo.nx; ++x) {
        const std::uint32_t r = v.rank[geo.linear(x, y, z)];
        ASSERT_LT(r, geo.cells());
        ASSERT_FALSE(used[r]);
        used[r] = 1;
        if (x > 0) {
          ASSERT_EQ(r, v.rank[geo.linear(x - 1, y, z)] + 1);
        }
      }
}

TEST(NeighbourGrid, ParticlesSortedInCellRankOrder) {
  const double h = 0.1;
  auto host = test_points<double>(2000, h, {0, 0, 0}, {0.8, 0.8, 0.8}, 3);
  NeighbourGrid<double> grid(exec::Backend::Cpu,
                             NeighbourGrid<double>::cover({0, 0, 0}, {0.8, 0.8, 0.8}, h));
  exec::DeviceBuffer<Vec3<double>> x(exec::Backend::Cpu);
  x.assign(host);
  grid.build({exec::Backend::Cpu}, x.data(), host.size());
  const auto perm = grid.permutation().to_host();
  const auto v = grid.view();
  // Along the sorted order the cell rank never decreases, and each particle lies in its cell's
  // range.
  std::uint32_t prev = 0;
  for (std::size_t i = 0; i < perm.size(); ++i) {
    int cx, cy, cz;
    v.geo.coords(host[perm[i]], cx, cy, cz);
    const std::uint32_t r = v.rank[v.geo.linear(cx, cy, cz)];
    EXPECT_GE(r, prev);
    prev = r;
    EXPECT_GE(i, v.start[r]);
    EXPECT_LT(i, v.end[r]);
  }
}

// build_keeping: the points inside the box (and NaNs) are sorted exactly as build() sorts them
// alone (the same order of their old indices, the same cell ranges); the ones outside follow in
// their old order and are in no cell. After drop_outside, a later build clears the tables
// properly (brute force again).
static void check_build_keeping(exec::Backend backend) {
  const double h = 0.1;
  const Vec3d lo{0, 0, 0}, hi{0.8, 0.6, 0.7};
  auto host = test_points<float>(3000, h, lo, hi, 17); // some points lie just outside
  host.push_back({std::numeric_limits<float>::quiet_NaN(), 0.3f, 0.3f}); // counts as inside
  const auto all = host;
  const KeepBox<float> keep{{0.05f, 0.02f, 0.0f}, {0.75f, 0.6f, 0.65f}};
  std::vector<std::uint32_t> inside, outside;
  for (std::uint32_t i = 0; i < host.size(); ++i)
    (keep.outside(host[i]) ? outside : inside).push_back(i);
  ASSERT_GT(outside.size(), 100u);
  const auto geo = NeighbourGrid<float>::cover(lo, hi, h);
  const exec::Exec ex{backend};
  NeighbourGrid<float> grid(backend, geo, 1, 2), alone(backend, geo, 1, 2);
  exec::DeviceBuffer<Vec3<float>> x(backend), xin(backend);
  // Every cell's range in a and b (the tables read back whole).
  auto same_cells = [&](const NeighbourGrid<float>& a, const NeighbourGrid<float>& b,
                        const char* what) {
    const std::size_t cells = geo.cells();
    auto table = [&](const std::uint32_t* p) {
      std::vector<std::uint32_t> t(cells);
      exec::copy_bytes(t.data(), exec::Backend::Cpu, p, backend, cells * sizeof(std::uint32_t));
      return t;
    };
    EXPECT_EQ(table(a.view().start), table(b.view().start)) << what;
    EXPECT_EQ(table(a.view().end), table(b.view().end)) << what;
  };
  for (int round = 0; round < 2; ++round) { // the second on the tables the first left
    x.assign(host);
    grid.build_keeping(ex, x.data(), host.size(), keep);
    const std::size_t kept = grid.kept();
    ASSERT_EQ(kept, inside.size());
    EXPECT_EQ(grid.kept(), kept); // read once, kept
    const auto perm = grid.permutation().to_host();
    ASSERT_EQ(perm.size(), host.size());
    std::vector<Vec3<float>> in;
    for (std::uint32_t i : inside)
      in.push_back(host[i]);
    xin.assign(in);
    alone.build(ex, xin.data(), in.size());
    const auto perm_in = alone.permutation().to_host();
    for (std::size_t k = 0; k < kept; ++k)
      ASSERT_EQ(perm[k], inside[perm_in[k]]) << "round " << round << ", k " << k;
    for (std::size_t k = kept; k < perm.size(); ++k)
      ASSERT_EQ(perm[k], outside[k - kept]) << "round " << round << ", k " << k;
    same_cells(grid, alone, "keeping against the inside alone");
    grid.drop_outside(kept);
    EXPECT_EQ(grid.permutation().size(), kept);
    EXPECT_THROW(grid.drop_outside(kept + 1), Error);
    host = in; // all inside now
    inside.resize(host.size());
    for (std::uint32_t i = 0; i < host.size(); ++i)
      inside[i] = i;
    outside.clear();
  }
  // Rows flagged out (KeepBox::rows, a rebuild's on N ranks: every third point, and with the box
  // the points outside it too) sort last in their order, as outside points do.
  {
    std::vector<std::uint32_t> flags(all.size()), in_idx, out_idx;
    for (std::uint32_t i = 0; i < all.size(); ++i)
      flags[i] = i % 3 == 0 ? 0u : 1u;
    exec::DeviceBuffer<std::uint32_t> dflags(backend, 0, "test.flags");
    dflags.assign(flags);
    for (const bool box : {false, true}) {
      KeepBox<float> k = KeepBox<float>::everywhere(dflags.data());
      if (box) {
        k.lo = keep.lo;
        k.hi = keep.hi;
      }
      in_idx.clear();
      out_idx.clear();
      for (std::uint32_t i = 0; i < all.size(); ++i)
        (flags[i] && !(box && keep.outside(all[i])) ? in_idx : out_idx).push_back(i);
      x.assign(all);
      grid.build_keeping(ex, x.data(), all.size(), k);
      ASSERT_EQ(grid.kept(), in_idx.size()) << "box " << box;
      std::vector<Vec3<float>> in;
      for (std::uint32_t i : in_idx)
        in.push_back(all[i]);
      xin.assign(in);
      alone.build(ex, xin.data(), in.size());
      const auto perm = grid.permutation().to_host();
      const auto perm_in = alone.permutation().to_host();
      for (std::size_t j = 0; j < in_idx.size(); ++j)
        ASSERT_EQ(perm[j], in_idx[perm_in[j]]) << "box " << box << ", k " << j;
      for (std::size_t j = in_idx.size(); j < perm.size(); ++j)
        ASSERT_EQ(perm[j], out_idx[j - in_idx.size()]) << "box " << box << ", k " << j;
      same_cells(grid, alone, "rows flagged out against the kept alone");
    }
  }
  // A keeping build left as it is (its keys name the outside), then a plain one: the tables
  // are a fresh grid's.
  x.assign(all);
  grid.build_keeping(ex, x.data(), all.size(), keep);
  EXPECT_LT(grid.kept(), all.size());
  grid.build(ex, x.data(), all.size());
  NeighbourGrid<float> fresh(backend, geo, 1, 2);
  fresh.build(ex, x.data(), all.size());
  EXPECT_EQ(grid.permutation().to_host(), fresh.permutation().to_host());
  same_cells(grid, fresh, "plain build after a keeping one");
}

TEST(NeighbourGrid, BuildKeepingSortsTheOutsideLastCpu) {
  check_build_keeping(exec::Backend::Cpu);
}
TEST(NeighbourGrid, BuildKeepingSortsTheOutsideLastCuda) {
  if (!exec::cuda_available())
    GTEST_SKIP() << "no CUDA device";
  check_build_keeping(exec::Backend::Cuda);
}

// With order levels L, particles go by cell rank and within a cell by the Morton code of their
// sub-cell (2^L a side), computed here in double from the position, bit by bit.
static void check_sub_cell_order(exec::Backend backend) {
  const double h = 0.1;
  const int levels = 2, n = 1 << levels;
  const Vec3d lo{0, 0, 0}, hi{0.8, 0.6, 0.7};
  auto host = test_points<double>(5000, h, lo, hi, 11);
  NeighbourGrid<double> grid(backend, NeighbourGrid<double>::cover(lo, hi, h), 1, levels);
  exec::DeviceBuffer<Vec3<double>> x(backend);
  x.assign(host);
  grid.build({backend}, x.data(), host.size());
  const auto perm = grid.permutation().to_host();
  NeighbourGrid<double> plain(exec::Backend::Cpu, NeighbourGrid<double>::cover(lo, hi, h));
  const auto geo = plain.geometry();
  const auto v = plain.view(); // ranks do not depend on the order levels
  auto sub = [&](const Vec3d& p, int axis, int c) {
    const double o = axis == 0 ? geo.origin.x : axis == 1 ? geo.origin.y : geo.origin.z;
    const double q = axis == 0 ? p.x : axis == 1 ? p.y : p.z;
    const int s = static_cast<int>(std::floor((q - o) / geo.cell * n)) - c * n;
    return std::clamp(s, 0, n - 1);
  };
  std::uint64_t prev = 0;
  std::size_t distinct = 0;
  for (std::size_t i = 0; i < perm.size(); ++i) {
    const Vec3d p = host[perm[i]];
    int cx, cy, cz;
    geo.coords(p, cx, cy, cz);
    const int s[3] = {sub(p, 0, cx), sub(p, 1, cy), sub(p, 2, cz)};
    std::uint64_t code = 0;
    for (int b = 0; b < levels; ++b)
      for (int a = 0; a < 3; ++a)
        code |= std::uint64_t((s[a] >> b) & 1) << (3 * b + a);
    const std::uint64_t key = std::uint64_t(v.rank[geo.linear(cx, cy, cz)]) << 6 | code;
    ASSERT_GE(key, prev) << "sorted position " << i;
    distinct += key != prev;
    prev = key;
  }
  EXPECT_GT(distinct, perm.size() / 4); // the sub-cells did split the cells
}

TEST(NeighbourGrid, SubCellOrderWithinCellsCpu) {
  check_sub_cell_order(exec::Backend::Cpu);
}
TEST(NeighbourGrid, SubCellOrderWithinCellsCuda) {
  if (!exec::cuda_available())
    GTEST_SKIP() << "no CUDA device";
  check_sub_cell_order(exec::Backend::Cuda);
}

TEST(NeighbourGrid, OrderLevelsFitTheSortKey) {
  using G = NeighbourGrid<float>;
  EXPECT_EQ(G::rank_bits(1), 1);
  EXPECT_EQ(G::rank_bits(2), 1);
  EXPECT_EQ(G::rank_bits(3), 2);
  EXPECT_EQ(G::rank_bits(1u << 20), 20);
  EXPECT_EQ(G::rank_bits((1u << 20) + 1), 21);
  // Ranks of up to 26 bits leave room for two levels (6 bits), 27-29 for one, 30 and more none.
  EXPECT_EQ(G::usable_order_levels(1u << 26, 2), 2);
  EXPECT_EQ(G::usable_order_levels((1u << 26) + 1, 2), 1);
  EXPECT_EQ(G::usable_order_levels(1u << 29, 2), 1);
  EXPECT_EQ(G::usable_order_levels((1u << 29) + 1, 2), 0);
  EXPECT_EQ(G::usable_order_levels(2000000000u, 1), 0);
  EXPECT_EQ(G::usable_order_levels(1000, 0), 0);
  EXPECT_EQ(G::usable_order_levels(1000, 1), 1);
}

TEST(NeighbourGrid, OrderLevelsOutOfRangeAreRefused) {
  const auto geo = NeighbourGrid<double>::cover({0, 0, 0}, {1, 1, 1}, 0.1);
  EXPECT_THROW(NeighbourGrid<double>(exec::Backend::Cpu, geo, 1, 3), Error);
  EXPECT_THROW(NeighbourGrid<double>(exec::Backend::Cpu, geo, 1, -1), Error);
}
