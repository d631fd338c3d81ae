// FluidSet::reorder gathers every field in one pass: it must equal a permutation done on the
// host, field by field, for a full sort and for a compaction, with and without the carried
// copies, over several reorders in a row (its sorted buffers are swapped in and reused).
#include "kernels/exec/Backend.hpp"
#include "kernels/particles/FluidSet.hpp"

#include "support/Bits.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <numeric>
#include <random>

namespace kf {
namespace {

using test::same_bits;

template <typename T>
struct HostFluid {
  std::vector<Vec3<T>> x, v, a;
  std::vector<T> m, rho, p, drho, drho_prev, vol;
  std::vector<std::uint64_t> id;
  std::vector<Vec4<T>> vp;

  static HostFluid random(std::size_t n, std::mt19937& rng) {
    std::uniform_real_distribution<double> u(-1, 1);
    auto vec = [&] { return Vec3<T>{T(u(rng)), T(u(rng)), T(u(rng))}; };
    auto scalar = [&] { return T(u(rng)); };
    HostFluid h;
    for (std::size_t i = 0; i < n; ++i) {
      h.x.push_back(vec());
      h.v.push_back(vec());
      h.a.push_back(vec());
      h.m.push_back(scalar());
      h.rho.push_back(scalar());
      h.p.push_back(scalar());
      h.drho.push_back(scalar());
      h.drho_prev.push_back(scalar());
      h.vol.push_back(scalar());
      h.id.push_back(1000 + 7 * i);
      h.vp.push_back({scalar(), scalar(), scalar(), scalar()});
    }
    return h;
  }
  void load(FluidSet<T>& f) const {
    f.resize(x.size());
    f.x.assign(x);
    f.v.assign(v);
    f.a.assign(a);
    f.m.assign(m);
    f.rho.assign(rho);
    f.p.assign(p);
    f.drho.assign(drho);
    f.drho_prev.assign(drho_prev);
    f.id.assign(id);
    f.view(); // sizes the copies
    f.vp.assign(vp);
    f.vol.assign(vol);
    f.xm.poison(); // reorder writes it whole
  }
};

template <typename U>
std::vector<U> permuted(const std::vector<U>& from, const std::vector<std::uint32_t>& perm) {
  std::vector<U> out;
  for (std::uint32_t j : perm)
    out.push_back(from[j]);
  return out;
}

template <typename T>
void check(exec::Backend backend) {
  std::mt19937 rng(11);
  const std::size_t n = 5003; // not a multiple of any block
  FluidSet<T> f(backend);
  HostFluid<T> h = HostFluid<T>::random(n, rng);
  h.load(f);
  exec::Exec ex{backend};
  exec::DeviceBuffer<std::uint32_t> perm(backend, 0, "test.perm");
  // Full sorts and compactions, alternating what is carried; state follows the host copy.
  const struct {
    std::size_t keep;
    bool acceleration, copies;
  } rounds[] = {{n, true, false},
                {n, false, true},
                {n - 500, true, true},
                {n - 900, false, false},
                {n - 1400, true, true}};
  for (const auto& r : rounds) {
    const std::size_t size = f.size();
    std::vector<std::uint32_t> order(size);
    std::iota(order.begin(), order.end(), 0u);
    std::shuffle(order.begin(), order.end(), rng);
    order.resize(r.keep);
    perm.assign(order);
    const auto a_before = f.a.to_host();
    const auto p_before = f.p.to_host();
    f.reorder(ex, perm, {r.acceleration, r.copies});
    ASSERT_EQ(f.size(), r.keep);
    h.x = permuted(h.x, order);
    h.v = permuted(h.v, order);
    h.m = permuted(h.m, order);
    h.rho = permuted(h.rho, order);
    h.drho = permuted(h.drho, order);
    h.drho_prev = permuted(h.drho_prev, order);
    h.id = permuted(h.id, order);
    EXPECT_TRUE(same_bits(f.x.to_host(), h.x));
    EXPECT_TRUE(same_bits(f.v.to_host(), h.v));
    EXPECT_TRUE(same_bits(f.m.to_host(), h.m));
    EXPECT_TRUE(same_bits(f.rho.to_host(), h.rho));
    EXPECT_TRUE(same_bits(f.drho.to_host(), h.drho));
    EXPECT_TRUE(same_bits(f.drho_prev.to_host(), h.drho_prev));
    EXPECT_TRUE(same_bits(f.id.to_host(), h.id));
    // The neighbour copy is (x, m) of the new order.
    std::vector<Vec4<T>> xm;
    for (std::size_t i = 0; i < r.keep; ++i)
      xm.push_back({h.x[i].x, h.x[i].y, h.x[i].z, h.m[i]});
    auto xm_now = f.xm.to_host();
    xm_now.resize(r.keep);
    EXPECT_TRUE(same_bits(xm_now, xm));
    // a: permuted, or left as it was (cut to the new size).
    if (r.acceleration) {
      h.a = permuted(h.a, order);
    } else {
      h.a = a_before;
      h.a.resize(r.keep);
    }
    EXPECT_TRUE(same_bits(f.a.to_host(), h.a));
    ASSERT_EQ(f.p.size(), r.keep);
    if (r.copies) {
      h.p = permuted(h.p, order);
      h.vp = permuted(h.vp, order);
      h.vol = permuted(h.vol, order);
      EXPECT_TRUE(same_bits(f.p.to_host(), h.p));
      auto vp = f.vp.to_host();
      auto vol = f.vol.to_host();
      ASSERT_GE(vp.size(), r.keep);
      ASSERT_GE(vol.size(), r.keep);
      vp.resize(r.keep);
      vol.resize(r.keep);
      EXPECT_TRUE(same_bits(vp, h.vp));
      EXPECT_TRUE(same_bits(vol, h.vol));
    } else {
      // Not carried: p keeps its values in place (the next density pass writes it); the host
      // copies stand for the next carried round's input, so reload vp and vol from them.
      h.p = p_before;
      h.p.resize(r.keep);
      EXPECT_TRUE(same_bits(f.p.to_host(), h.p));
      h.vp.resize(r.keep);
      h.vol.resize(r.keep);
      f.view();
      f.vp.assign(h.vp);
      f.vol.assign(h.vol);
    }
  }
  // The set grows again (a drip): view() must size every copy, swapped or not.
  f.resize(n);
  const FluidView<T> view = f.view();
  EXPECT_EQ(view.n, n);
  EXPECT_GE(f.xm.size(), n);
  EXPECT_GE(f.vp.size(), n);
  EXPECT_GE(f.vol.size(), n);
}

TEST(FluidReorder, MatchesHostPermutationCpuFloat) {
  check<float>(exec::Backend::Cpu);
}
TEST(FluidReorder, MatchesHostPermutationCpuDouble) {
  check<double>(exec::Backend::Cpu);
}
TEST(FluidReorder, MatchesHostPermutationCudaFloat) {
  if (!exec::cuda_available())
    GTEST_SKIP() << "no CUDA device";
  check<float>(exec::Backend::Cuda);
}

} // namespace
} // namespace kf
