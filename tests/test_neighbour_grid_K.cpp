// The neighbour grid returns exactly the brute-force neighbour sets, on every backend.
#include "kernels/exec/Algorithms.hpp"
#include "kernels/grid/NeighbourGrid.hpp"

#include <gtest/gtest.h>

#include <algorithm>
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

template <typename T>
void check_against_brute_force(exec::Backend backend) {
  const double h = 0.1;
  const Vec3d lo{0, 0, 0}, hi{1.0, 0.3, 0.55};
  auto host = test_points<T>(3000, h, lo, hi, 42);
  const std::size_t n = host.size();
  NeighbourGrid<T> grid(backend, NeighbourGrid<T>::cover(lo, hi, h));
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
  exec::DeviceBuffer<std::uint32_t> count(backend, n), checksum(backend, n);
  count.poison();
  checksum.poison();
  const auto view = grid.view();
  const Vec3<T>* px = x.data();
  std::uint32_t* pc = count.data();
  std::uint32_t* ps = checksum.data();
  exec::for_each(
      ex, n,
      [=] KF_HD(std::size_t i) {
        std::uint32_t c = 0, s = 0;
        view.for_each_candidate(px[i], [&](std::uint32_t j) {
          if (norm2(px[i] - px[j]) < h2) {
            ++c;
            s += j * 2654435761u; // order-free fingerprint of the set
          }
        });
        pc[i] = c;
        ps[i] = s;
      },
      "test.neighbours");
  auto got_count = count.to_host();
  auto got_sum = checksum.to_host();

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
      hv.for_each_candidate(sorted[i], [&](std::uint32_t j) {
        if (norm2(sorted[i] - sorted[j]) < h2)
          viagrid.insert(j);
      });
      EXPECT_EQ(brute, viagrid) << "particle " << i;
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

TEST(NeighbourGrid, CellsSortedInMortonRankOrder) {
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
