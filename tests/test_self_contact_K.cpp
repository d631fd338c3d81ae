// Knit self-collision kernel (Eq. 7, 8 as corrected in DESIGN §10) against an independent
// all-pairs reference: forces, pair counts and penalty energy; momentum; the rest-mesh exclusion;
// the corrected signs (repulsion, friction against the sliding). On the CPU, and on the GPU when
// one is present.
#include "kernels/knit/SelfContact.hpp"
#include "support/VecCast.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

using namespace kf;

namespace {

constexpr double kR = 0.01;

struct Cloud {
  std::vector<Vec3d> x, v, rest;
  std::vector<double> m;
  std::vector<std::uint16_t> piece;
  std::vector<std::uint32_t> handle;
};

/// Points dense enough that most have several overlapping neighbours, in two pieces; rest
/// positions are the current ones jittered, so some close pairs are excluded and some not.
Cloud make_cloud(std::size_t n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  Cloud c;
  const double box = 0.12;
  for (std::size_t i = 0; i < n; ++i) {
    const Vec3d x{box * u(rng), box * u(rng), 0.5 * box * u(rng)};
    c.x.push_back(x);
    c.v.push_back({u(rng) - 0.5, u(rng) - 0.5, u(rng) - 0.5});
    c.rest.push_back(x + Vec3d{0.04 * (u(rng) - 0.5), 0.04 * (u(rng) - 0.5), 0});
    c.m.push_back(1e-4 * (0.5 + u(rng)));
    c.piece.push_back(static_cast<std::uint16_t>(i % 3 == 0));
    c.handle.push_back(i % 17 == 0 ? 0u : kFreePoint);
  }
  return c;
}

SelfContactParams<double> params() {
  SelfContactParams<double> p;
  p.radius = kR;
  p.exclusion2 = 9 * kR * kR;
  p.k = 50;
  p.zeta = 0.3;
  p.friction = 0.4;
  return p;
}

/// The reference: Eq. 7 and 8 as DESIGN §10 corrects them, written out pair by pair.
Vec3d reference_force(const Cloud& c, std::size_t i, std::size_t j,
                      const SelfContactParams<double>& p) {
  const Vec3d d = c.x[i] - c.x[j];
  const double r = norm(d), reach = 2 * p.radius;
  if (r >= reach || r == 0)
    return {0, 0, 0};
  const Vec3d n = d * (1 / r);
  const double mred = c.m[i] * c.m[j] / (c.m[i] + c.m[j]);
  const double gamma = 2 * std::sqrt(p.k * mred); // critical damping of the pair
  const Vec3d dv = c.v[i] - c.v[j];
  const double vn = dot(dv, n);
  const double fn = std::max(0.0, p.k * (reach - r) - p.zeta * gamma * vn);
  const Vec3d vt = dv - n * vn;
  const double st = norm(vt);
  Vec3d f = n * fn;
  if (st > 0)
    f -= vt * (std::min(p.friction * fn, gamma * st) / st);
  return f;
}

bool excluded(const Cloud& c, std::size_t i, std::size_t j, const SelfContactParams<double>& p) {
  return c.piece[i] == c.piece[j] && norm2(c.rest[i] - c.rest[j]) < p.exclusion2;
}

/// Where the points are when the forces are taken, against where the grid was sorted.
enum class Motion {
  None,         // sorted where they are
  WithinSkin,   // every point moved less than the skin since the sort: the grid still holds
  PastListSkin, // every point moved 1.2-1.95 skins, no sort: the lists may miss a partner, a
                // walk of the cells (margin 2 skins) not
  PastSkin,     // some points moved past the margin and no sort followed: the all-pairs fallback
};

template <typename T>
void check(exec::Backend backend, Motion motion = Motion::None, std::uint32_t list_capacity = 512) {
  const Cloud sorted_at = make_cloud(1500, 11);
  Cloud c = sorted_at;
  const std::size_t n = c.x.size();
  const double skin = (3 * kR - 2 * kR) / 2; // the grid's below: half its cells' margin
  {
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> u(-1, 1);
    for (std::size_t i = 0; i < n; ++i) {
      const Vec3d r{u(rng), u(rng), u(rng) + 1e-3};
      const Vec3d dir = r * (1 / norm(r));
      if (motion == Motion::WithinSkin)
        c.x[i] += dir * (0.9 * skin * std::abs(u(rng)));
      else if (motion == Motion::PastListSkin)
        c.x[i] += dir * ((1.2 + 0.75 * std::abs(u(rng))) * skin);
      else if (motion == Motion::PastSkin && i % 10 == 0)
        c.x[i] += dir * (2.5 * skin);
    }
  }
  const auto p = params();
  exec::Exec ex{backend};
  KnitSet<T> set(backend);
  set.resize(n);
  set.x.assign(test::vec_cast_all<T>(sorted_at.x));
  set.v.assign(test::vec_cast_all<T>(c.v));
  set.x_rest.assign(test::vec_cast_all<T>(c.rest));
  set.m.assign(std::vector<T>(c.m.begin(), c.m.end()));
  set.piece.assign(c.piece);
  set.handle.assign(c.handle);
  std::vector<std::uint64_t> id(n);
  for (std::size_t i = 0; i < n; ++i)
    id[i] = 1000 + 3 * i; // ids need not be indices
  set.id.assign(id);
  set.a.assign(std::vector<Vec3<T>>(n, Vec3<T>{}));

  SelfContactParams<T> pt{T(p.radius), T(p.exclusion2), T(p.k), T(p.zeta), T(p.friction)};
  // Cells wider than 2R: candidates are a superset, the kernel must filter by distance itself.
  KnitSelfContact<T> sc(backend, NeighbourGrid<T>::cover({0, 0, 0}, {0.12, 0.12, 0.06}, 3 * kR), pt,
                        list_capacity);
  sc.sync(ex, set);
  if (motion != Motion::None) {
    sc.begin_step(ex, set, T(0)); // no motion expected: the substeps watch on the device
    ASSERT_FALSE(sc.checks_on_host());
  }
  set.x.assign(test::vec_cast_all<T>(c.x));
  sc.update(ex, set);
  sc.add_forces(ex, set);
  EXPECT_EQ(sc.sorts(), 1u) << "the forces must come from the grid sorted at the old positions";
  if (motion != Motion::None) {
    sc.sync(ex, set); // reads the watched motion
    const bool past = motion == Motion::PastSkin || motion == Motion::PastListSkin;
    EXPECT_EQ(sc.stale_steps(), past ? 1u : 0u);
    EXPECT_EQ(sc.sorts(), past ? 2u : 1u);
  }
  const SelfContactStats st = sc.stats(ex, set);
  const auto a = set.a.to_host();

  const double tol = std::is_same_v<T, float> ? 2e-4 : 1e-10;
  std::uint64_t pairs = 0, excluded_close = 0;
  double energy = 0, fscale = 0;
  Vec3d momentum{0, 0, 0};
  for (std::size_t i = 0; i < n; ++i) {
    Vec3d f{0, 0, 0};
    for (std::size_t j = 0; j < n; ++j) {
      if (j == i)
        continue;
      const double r = norm(c.x[i] - c.x[j]);
      if (excluded(c, i, j, p)) {
        excluded_close += r < 2 * kR;
        continue;
      }
      f += reference_force(c, i, j, p);
      if (r < 2 * kR && i < j) {
        ++pairs;
        energy += 0.5 * p.k * (2 * kR - r) * (2 * kR - r);
      }
    }
    fscale = std::max(fscale, norm(f));
    const Vec3d expect = c.handle[i] == kFreePoint ? f * (1 / c.m[i]) : Vec3d{0, 0, 0};
    const Vec3d got = vec_cast<double>(a[i]);
    ASSERT_LE(norm(got - expect), tol * (1 + norm(expect))) << "point " << i;
    if (c.handle[i] == kFreePoint)
      momentum += got * c.m[i];
    else
      momentum += f; // a handle point's share of the pair forces, which its a leaves out
  }
  ASSERT_GT(pairs, n) << "the cloud is too sparse to test much";
  ASSERT_GT(excluded_close, 100u) << "the exclusion is not exercised";
  EXPECT_EQ(st.contacts, pairs);
  EXPECT_NEAR(st.energy, energy, 1e-4 * energy);
  // Pair forces cancel: the total is rounding next to the largest force on one point.
  EXPECT_LT(norm(momentum), (std::is_same_v<T, float> ? 1e-4 : 1e-12) * fscale * std::sqrt(n));
}

} // namespace

TEST(SelfContact, MatchesAllPairsReferenceCpuDouble) {
  check<double>(exec::Backend::Cpu);
}
TEST(SelfContact, MatchesAllPairsReferenceCpuFloat) {
  check<float>(exec::Backend::Cpu);
}
TEST(SelfContact, MatchesAllPairsReferenceCudaFloat) {
  if (!exec::cuda_available())
    GTEST_SKIP() << "no CUDA device";
  check<float>(exec::Backend::Cuda);
}
// Rows of 8: most points have more allowed partners within a cell edge and walk their cells
// instead; the two kinds of rows side by side give the same forces.
TEST(SelfContact, OverflowingListsWalkTheirCellsCpu) {
  check<double>(exec::Backend::Cpu, Motion::None, 8);
  check<double>(exec::Backend::Cpu, Motion::WithinSkin, 8);
}
TEST(SelfContact, OverflowingListsWalkTheirCellsCuda) {
  if (!exec::cuda_available())
    GTEST_SKIP() << "no CUDA device";
  check<float>(exec::Backend::Cuda, Motion::None, 8);
}

// Points moved since the sort, with no sort between: within the skin the kept grid finds every
// pair; past it the force pass sees the watched motion and sums over all pairs.
TEST(SelfContact, MovedWithinSkinKeepsTheGridCpu) {
  check<double>(exec::Backend::Cpu, Motion::WithinSkin);
}
TEST(SelfContact, MovedPastListSkinWalksTheCellsCpu) {
  check<double>(exec::Backend::Cpu, Motion::PastListSkin);
}
TEST(SelfContact, MovedPastSkinFallsBackToAllPairsCpu) {
  check<double>(exec::Backend::Cpu, Motion::PastSkin);
}
TEST(SelfContact, MovedPastSkinFallsBackToAllPairsCuda) {
  if (!exec::cuda_available())
    GTEST_SKIP() << "no CUDA device";
  check<float>(exec::Backend::Cuda, Motion::WithinSkin);
  check<float>(exec::Backend::Cuda, Motion::PastListSkin);
  check<float>(exec::Backend::Cuda, Motion::PastSkin);
}

// The corrected signs: approaching points are pushed apart (Eq. 7 as printed would pull them
// together), and friction opposes the sliding (Eq. 8 as printed pushes along it).
TEST(SelfContact, RepelsOnOverlapAndFrictionOpposesSliding) {
  const auto p = params();
  Vec3<double> f;
  const Vec3<double> d{1.5 * kR, 0, 0}; // i to the right of j, overlapping by R / 2
  ASSERT_TRUE(self_contact_force(d, Vec3<double>{0, 0, 0}, 1e-4, 1e-4, p, f));
  EXPECT_NEAR(f.x, p.k * 0.5 * kR, 1e-12);
  EXPECT_EQ(f.y, 0.0);
  // Sliding fast along +y: the Coulomb cap mu F_n, against the motion.
  ASSERT_TRUE(self_contact_force(d, Vec3<double>{0, 10, 0}, 1e-4, 1e-4, p, f));
  EXPECT_NEAR(f.y, -p.friction * p.k * 0.5 * kR, 1e-12);
  // Sliding slowly: viscous, vanishing with the speed (no chatter at rest).
  ASSERT_TRUE(self_contact_force(d, Vec3<double>{0, 1e-9, 0}, 1e-4, 1e-4, p, f));
  EXPECT_LT(f.y, 0.0);
  EXPECT_GT(f.y, -1e-9);
  // Separating fast: damping may cancel the push but never pulls.
  ASSERT_TRUE(self_contact_force(d, Vec3<double>{100, 0, 0}, 1e-4, 1e-4, p, f));
  EXPECT_EQ(f.x, 0.0);
  // Out of reach: nothing.
  EXPECT_FALSE(
      self_contact_force(Vec3<double>{2.0001 * kR, 0, 0}, Vec3<double>{0, 0, 0}, 1e-4, 1e-4, p, f));
}
