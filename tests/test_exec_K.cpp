// The execution layer on every backend this binary has: for_each, transform_reduce, sort_by_key,
// exclusive_scan, gather and DeviceBuffer, each checked against the standard library, plus a
// CPU-vs-CUDA comparison. Compiled by nvcc in the CUDA build (the _K suffix), so the lambdas below
// run as CUDA kernels there.
#include "core/Error.hpp"
#include "kernels/exec/Algorithms.hpp"
#include "kernels/exec/Backend.hpp"
#include "kernels/exec/DeviceBuffer.hpp"
#include "kernels/exec/PeakByLabel.hpp"
#include "kernels/exec/PendingRead.hpp"
#include "kernels/exec/ScanOnDevice.hpp"
#include "kernels/exec/Streams.hpp"
#include "kernels/integrate/StepSize.hpp"

#if defined(KF_WITH_CUDA) && defined(__CUDACC__)
#include "kernels/exec/CudaCheck.hpp"
#endif

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <numeric>
#include <random>
#include <string>
#include <utility>
#include <vector>

// Kernel-launching helpers live in named free functions: nvcc's extended lambdas may not be
// defined inside gtest's test bodies (private member functions of local classes).
namespace kf_exec_test {

using kf::exec::Backend;
using kf::exec::DeviceBuffer;
using kf::exec::Exec;

std::vector<std::uint32_t> random_u32(std::size_t n, std::uint32_t max, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<std::uint32_t> dist(0, max);
  std::vector<std::uint32_t> v(n);
  for (auto& x : v)
    x = dist(rng);
  return v;
}

std::vector<double> random_f64(std::size_t n, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> dist(-1000.0, 1000.0);
  std::vector<double> v(n);
  for (auto& x : v)
    x = dist(rng);
  return v;
}

std::uint32_t key_mask(int key_bits) {
  return key_bits >= 32 ? 0xFFFFFFFFu : (std::uint32_t{1} << key_bits) - 1u;
}

/// out[i] = 3i + 1 for i < n (never the poison value for the sizes used).
void write_index(const Exec& ex, DeviceBuffer<std::uint32_t>& out, std::size_t n) {
  std::uint32_t* p = out.data();
  kf::exec::for_each(
      ex, n, [=] KF_HD(std::size_t i) { p[i] = static_cast<std::uint32_t>(3 * i + 1); },
      "test.write_index");
}
void write_index(const Exec& ex, DeviceBuffer<std::uint32_t>& out) {
  write_index(ex, out, out.size());
}

/// out[i] = 2^21 steps of a 32-bit LCG from in[i] (from i where `in` is null): a few
/// milliseconds a thread on an H200, each element's steps dependent, so that a pass of a few
/// hundred elements keeps a handful of SMs busy that long and a pass on another stream, with no
/// order between the two, runs beside it.
void mix_slowly(const Exec& ex, const std::uint32_t* in, DeviceBuffer<std::uint32_t>& out) {
  std::uint32_t* p = out.data();
  kf::exec::for_each(
      ex, out.size(),
      [=] KF_HD(std::size_t i) {
        std::uint32_t x = in ? in[i] : static_cast<std::uint32_t>(i);
        for (int k = 0; k < (1 << 21); ++k)
          x = x * 1664525u + 1013904223u;
        p[i] = x;
      },
      "test.mix_slowly");
}
/// out[i] = in[i] ^ salt.
void xor_with(const Exec& ex, const DeviceBuffer<std::uint32_t>& in,
              DeviceBuffer<std::uint32_t>& out, std::uint32_t salt) {
  const std::uint32_t* a = in.data();
  std::uint32_t* b = out.data();
  kf::exec::for_each(
      ex, out.size(), [=] KF_HD(std::size_t i) { b[i] = a[i] ^ salt; }, "test.xor_with");
}

/// out[i] = 3i + 1 for the rows `rows` names (kf::exec::for_rows).
void write_index_rows(const Exec& ex, DeviceBuffer<std::uint32_t>& out,
                      const kf::exec::Rows& rows) {
  std::uint32_t* p = out.data();
  kf::exec::for_rows(
      ex, rows, [=] KF_HD(std::size_t i) { p[i] = static_cast<std::uint32_t>(3 * i + 1); },
      "test.write_index_rows");
}

/// A float computation whose rounding cannot differ between host and device (a single multiply
/// cannot be contracted into an FMA), plus an integer hash.
void mix(const Exec& ex, const DeviceBuffer<double>& in, DeviceBuffer<double>& out_f,
         DeviceBuffer<std::uint32_t>& out_u) {
  const double* a = in.data();
  double* f = out_f.data();
  std::uint32_t* u = out_u.data();
  kf::exec::for_each(
      ex, in.size(),
      [=] KF_HD(std::size_t i) {
        f[i] = a[i] * 1.25;
        std::uint32_t h = static_cast<std::uint32_t>(i) * 2654435761u;
        u[i] = h ^ (h >> 13);
      },
      "test.mix");
}

template <typename Op>
double reduce_f64(const Exec& ex, const DeviceBuffer<double>& v, double init, Op op) {
  const double* p = v.data();
  return kf::exec::transform_reduce(
      ex, v.size(), init, op, [=] KF_HD(std::size_t i) { return p[i]; }, "test.reduce_f64");
}

std::uint64_t sum_u64(const Exec& ex, const DeviceBuffer<std::uint32_t>& v, std::uint64_t init) {
  const std::uint32_t* p = v.data();
  return kf::exec::transform_reduce(
      ex, v.size(), init, kf::exec::SumOp{},
      [=] KF_HD(std::size_t i) { return static_cast<std::uint64_t>(p[i]); }, "test.sum_u64");
}

// acc[0] = op(acc[0], reduction): the accumulator stays in the backend's memory.
template <typename Op>
void reduce_f64_into(const Exec& ex, const DeviceBuffer<double>& v, Op op,
                     DeviceBuffer<double>& acc) {
  const double* p = v.data();
  kf::exec::transform_reduce_into(
      ex, v.size(), op, [=] KF_HD(std::size_t i) { return p[i]; }, acc.data(),
      "test.reduce_f64_into");
}

/// max_into over |v[i]| (non-negative) that also copies v to out: the pass must visit every i.
template <typename T>
struct AbsAndCopy {
  const T* v;
  T* out;
  KF_HD T operator()(std::size_t i) const {
    out[i] = v[i];
    return v[i] < T(0) ? -v[i] : v[i];
  }
};
template <typename T>
void max_abs_into(const Exec& ex, const DeviceBuffer<T>& v, DeviceBuffer<T>& out,
                  DeviceBuffer<T>& acc) {
  kf::exec::max_into(ex, v.size(), AbsAndCopy<T>{v.data(), out.data()}, acc.data(),
                     "test.max_into");
}

double reduce_f64_to(const Exec& ex, const DeviceBuffer<double>& v, DeviceBuffer<double>& out) {
  const double* p = v.data();
  out.poison();
  kf::exec::transform_reduce_to(
      ex, v.size(), 1.5, kf::exec::SumOp{}, [=] KF_HD(std::size_t i) { return p[i]; }, out.data(),
      "test.reduce_f64_to");
  return out.to_host()[0];
}

/// out[i] = sum over k < i % 37 of (i + k), split over the lanes (exact in double), written by
/// lane 0; every lane also counts its visits so a lane that skipped or repeated work shows.
struct LaneSum {
  double* out;
  std::uint32_t* visits;
  KF_HD void operator()(std::size_t i, kf::exec::Lanes g = {}) const {
    double part = 0;
    std::uint32_t seen = 0;
    for (std::size_t k = g.lane; k < i % 37; k += g.size) {
      part += double(i + k);
      ++seen;
    }
    const double total = g.sum(part);
    const std::uint32_t all = g.sum(seen);
    if (g.lane == 0) {
      out[i] = total;
      visits[i] = all;
    }
  }
};
template <unsigned G>
void lane_sums(const Exec& ex, DeviceBuffer<double>& out, DeviceBuffer<std::uint32_t>& visits) {
  kf::exec::for_each_lanes<G>(ex, out.size(), LaneSum{out.data(), visits.data()}, "test.lanes");
}

/// for_each_chunk: every element of [0, n) is some lane's first + lane, once; per element the
/// group queries over its chunk: the first lane whose element is 3 mod 5, that lane's element
/// (broadcast), the smallest and largest element mod 97 over the chunk's lanes, the ballot of
/// the lanes whose element is even (its bit count, and the bits below this lane), and the box
/// of the points (e mod 97, -(e mod 89), e mod 13) over the chunk's lanes (min_each, max_each),
/// and the smallest 7919 e mod 1009 over them as a 64-bit word (reduce).
constexpr std::size_t kChunkAnswers = 9;
struct ChunkQueries {
  std::size_t n;
  std::int32_t* out; // kChunkAnswers per element
  KF_HD void operator()(std::size_t first, kf::exec::Lanes g) const {
    const std::size_t e = first + g.lane;
    const bool mine = e < n;
    const unsigned lead = g.first_set(mine && e % 5 == 3);
    const int from = g.broadcast(mine ? int(e) : -1, lead < g.size ? lead : 0);
    const int lo = g.min(mine ? int(e % 97) : 1000), hi = g.max(mine ? int(e % 97) : -1);
    const bool any = g.any(mine && e % 5 == 3);
    const unsigned even = g.ballot(mine && e % 2 == 0);
    const float big = 1e30f;
    const kf::Vec3<float> p{float(e % 97), -float(e % 89), float(e % 13)};
    const kf::Vec3<float> blo = g.min_each(mine ? p : kf::Vec3<float>{big, big, big});
    const kf::Vec3<float> bhi = g.max_each(mine ? p : kf::Vec3<float>{-big, -big, -big});
    const std::uint64_t least =
        g.reduce(mine ? std::uint64_t(e * 7919 % 1009) : ~std::uint64_t(0),
                 [](std::uint64_t a, std::uint64_t b) { return b < a ? b : a; });
    if (mine) {
      std::int32_t* o = out + kChunkAnswers * e;
      o[0] = int(lead) + (any ? 0 : 100);
      o[1] = lead < g.size ? from : -2;
      o[2] = lo;
      o[3] = hi;
      o[4] = int(kf::popcount(even));
      o[5] = int(g.count_below(even));
      o[6] = int(blo.x) * 10000 + int(-blo.y) * 100 + int(blo.z);
      o[7] = int(bhi.x) * 10000 + int(-bhi.y) * 100 + int(bhi.z);
      o[8] = int(least);
    }
  }
};
template <unsigned G>
void check_chunks(const Exec& ex, Backend b) {
  for (std::size_t n : {std::size_t(1), std::size_t(31), std::size_t(1000), std::size_t(4099)}) {
    DeviceBuffer<std::int32_t> out(b, kChunkAnswers * n, "test.chunks");
    out.poison();
    kf::exec::for_each_chunk<G>(ex, n, ChunkQueries{n, out.data()}, "test.chunks");
    const auto o = out.to_host();
    const std::size_t size = b == Backend::Cuda ? G : 1; // lanes a chunk
    for (std::size_t e = 0; e < n; ++e) {
      const std::size_t first = e / size * size, last = std::min(n, first + size);
      std::size_t lead = size;
      int lo = 1000, hi = -1, evens = 0, evens_below = 0, least = 2000;
      int box_lo[3] = {1000, 1000, 1000}, box_hi[3] = {-1, -1, -1}; // x, -y, z
      for (std::size_t k = first; k < last; ++k) {
        if (lead == size && k % 5 == 3)
          lead = k - first;
        lo = std::min(lo, int(k % 97));
        hi = std::max(hi, int(k % 97));
        evens += k % 2 == 0;
        evens_below += k % 2 == 0 && k < e;
        least = std::min(least, int(k * 7919 % 1009));
        const int c[3] = {int(k % 97), int(k % 89), int(k % 13)};
        for (int a = 0; a < 3; ++a) {
          box_lo[a] = std::min(box_lo[a], c[a]);
          box_hi[a] = std::max(box_hi[a], c[a]);
        }
      }
      const std::int32_t* r = o.data() + kChunkAnswers * e;
      ASSERT_EQ(r[0], int(lead) + (lead < size ? 0 : 100)) << "G " << G << " e " << e;
      ASSERT_EQ(r[1], lead < size ? int(first + lead) : -2) << "G " << G << " e " << e;
      ASSERT_EQ(r[2], lo) << "G " << G << " e " << e;
      ASSERT_EQ(r[3], hi) << "G " << G << " e " << e;
      ASSERT_EQ(r[4], evens) << "G " << G << " e " << e;
      ASSERT_EQ(r[5], evens_below) << "G " << G << " e " << e;
      // min over x and z, and over y = -(k mod 89): the largest k mod 89, and the reverse.
      ASSERT_EQ(r[6], box_lo[0] * 10000 + box_hi[1] * 100 + box_lo[2]) << "G " << G << " e " << e;
      ASSERT_EQ(r[7], box_hi[0] * 10000 + box_lo[1] * 100 + box_hi[2]) << "G " << G << " e " << e;
      ASSERT_EQ(r[8], least) << "G " << G << " e " << e;
    }
  }
}

/// p[i] = value for i < n (a kernel queued behind a pending read).
void set_all(const Exec& ex, DeviceBuffer<double>& buf, double value) {
  kf::exec::for_each(ex, buf.size(), kf::exec::FillWith<double>{buf.data(), value}, "test.set");
}

/// The step plan of the device, for bounds and a remainder, read back.
kf::StepPlan<float> plan_on(const Exec& ex, const kf::FluidStepRule& rule,
                            kf::MotionBounds<float> mb, double remaining) {
  DeviceBuffer<kf::MotionBounds<float>> bounds(ex.backend, 0, "bounds");
  bounds.assign(std::vector<kf::MotionBounds<float>>{mb});
  DeviceBuffer<kf::StepPlan<float>> plan(ex.backend, 1, "plan");
  plan.poison();
  kf::plan_fluid_step(ex, rule, bounds.data(), remaining, plan.data());
  return plan.to_host()[0];
}

/// A fluid step rule with every limit active (the plan's tests).
kf::FluidStepRule test_step_rule() {
  kf::FluidStepRule rule;
  rule.limit = 1e-3;
  rule.cfl = 0.1;
  rule.h = 0.0121;
  rule.sound = 34.3;
  rule.force_factor = 0.25;
  rule.dt_min = 1e-9;
  return rule;
}

} // namespace kf_exec_test

namespace {

using namespace kf_exec_test;

class ExecTest : public ::testing::TestWithParam<Backend> {
protected:
  void SetUp() override {
    if (GetParam() == Backend::Cuda && !kf::exec::cuda_available())
      GTEST_SKIP() << "no CUDA device"
                   << (kf::exec::cuda_compiled() ? "" : " (built without CUDA)");
  }
  Exec ex() const { return Exec{GetParam()}; }
  Backend b() const { return GetParam(); }
};

// Sizes around the CUDA block (256) and the reduction grid cap (512 blocks of 256).
const std::size_t kSizes[] = {1,    2,      255,       256,           257,
                              1000, 100003, 512 * 256, 512 * 256 + 1, 1u << 20};

TEST_P(ExecTest, ForEachWritesEveryElement) {
  for (std::size_t n : kSizes) {
    DeviceBuffer<std::uint32_t> out(b(), n, "out");
    out.poison();
    write_index(ex(), out);
    const auto h = out.to_host();
    std::size_t bad = 0;
    for (std::size_t i = 0; i < n; ++i)
      bad += h[i] != 3 * i + 1;
    EXPECT_EQ(bad, 0u) << "n=" << n;
  }
}

// A pass over rows: a range, an index list, or the flagged rows of a range (a rank's owned rows
// among its ghosts). Every named row written once, every other left poisoned.
TEST_P(ExecTest, ForRowsVisitsExactlyTheNamedRows) {
  for (std::size_t n : {std::size_t{257}, std::size_t{100003}}) {
    const auto flags = random_u32(n, 3, 7); // about a quarter of the rows flagged 0
    std::vector<std::uint32_t> listed;
    for (std::size_t i = 0; i < n; ++i)
      if (flags[i] != 0)
        listed.push_back(static_cast<std::uint32_t>(i));
    DeviceBuffer<std::uint32_t> only(b(), n, "only"), index(b(), listed.size(), "index");
    only.assign(flags);
    index.assign(listed);
    for (int mode = 0; mode < 3; ++mode) {
      DeviceBuffer<std::uint32_t> out(b(), n, "out");
      out.poison();
      const kf::exec::Rows rows = mode == 0   ? kf::exec::Rows{nullptr, n}
                                  : mode == 1 ? kf::exec::Rows{index.data(), index.size()}
                                              : kf::exec::Rows{nullptr, n, only.data()};
      write_index_rows(ex(), out, rows);
      const auto h = out.to_host();
      std::size_t bad = 0;
      for (std::size_t i = 0; i < n; ++i)
        bad += h[i] != (mode == 0 || flags[i] != 0 ? 3 * i + 1 : 0xFFFFFFFFu);
      EXPECT_EQ(bad, 0u) << "n=" << n << ", mode " << mode;
    }
  }
}

// n = 0 launches nothing: no element of a live buffer is written (a launch of one block without
// the bounds check would write p[0]), no error is raised (CUDA refuses a grid of 0 blocks), and
// the backend still runs the next launch.
TEST_P(ExecTest, ForEachOfNothingWritesNothingAndRaisesNothing) {
  DeviceBuffer<std::uint32_t> empty(b(), 0, "empty");
  EXPECT_NO_THROW(write_index(ex(), empty));
  DeviceBuffer<std::uint32_t> sentinel(b(), 300, "sentinel");
  sentinel.poison();
  EXPECT_NO_THROW(write_index(ex(), sentinel, 0));
  EXPECT_NO_THROW(kf::exec::synchronize(b())); // an asynchronous launch error shows here
  for (std::uint32_t x : sentinel.to_host())
    ASSERT_EQ(x, 0xFFFFFFFFu) << "an empty launch wrote an element";
  write_index(ex(), sentinel, 257);
  const auto h = sentinel.to_host();
  for (std::size_t i = 0; i < h.size(); ++i)
    ASSERT_EQ(h[i], i < 257 ? 3 * i + 1 : 0xFFFFFFFFu) << "after the empty launch, i=" << i;
}

TEST_P(ExecTest, FillSetsEveryElement) {
  DeviceBuffer<double> buf(b(), 1001, "buf");
  buf.poison();
  kf::exec::fill(ex(), buf, 2.5, "test.fill");
  for (double x : buf.to_host())
    ASSERT_EQ(x, 2.5);
}

TEST_P(ExecTest, TransformReduceMatchesStd) {
  for (std::size_t n : kSizes) {
    const auto hf = random_f64(n, 11 + static_cast<std::uint32_t>(n));
    const auto hu = random_u32(n, 0xFFFFFFFFu, 17 + static_cast<std::uint32_t>(n));
    DeviceBuffer<double> f(b(), 0, "f");
    DeviceBuffer<std::uint32_t> u(b(), 0, "u");
    f.assign(hf);
    u.assign(hu);

    // Integer sums are exact; init must be added once, not once per thread or block.
    std::uint64_t want_u = 7;
    for (auto x : hu)
      want_u += x;
    EXPECT_EQ(sum_u64(ex(), u, 7), want_u) << "n=" << n;

    double want_sum = 0, abs_sum = 0;
    for (double x : hf)
      want_sum += x, abs_sum += std::fabs(x);
    EXPECT_NEAR(reduce_f64(ex(), f, 0.0, kf::exec::SumOp{}), want_sum, 1e-12 * abs_sum + 1e-12)
        << "n=" << n;
    EXPECT_EQ(reduce_f64(ex(), f, -1e300, kf::exec::MaxOp{}),
              *std::max_element(hf.begin(), hf.end()))
        << "n=" << n;
    EXPECT_EQ(reduce_f64(ex(), f, 1e300, kf::exec::MinOp{}),
              *std::min_element(hf.begin(), hf.end()))
        << "n=" << n;
    // An init that wins must come back unchanged.
    EXPECT_EQ(reduce_f64(ex(), f, 5000.0, kf::exec::MaxOp{}), 5000.0) << "n=" << n;
    EXPECT_EQ(reduce_f64(ex(), f, -5000.0, kf::exec::MinOp{}), -5000.0) << "n=" << n;
  }
}

TEST_P(ExecTest, TransformReduceOfNothingIsInit) {
  DeviceBuffer<double> f(b(), 0, "f");
  DeviceBuffer<std::uint32_t> u(b(), 0, "u");
  EXPECT_EQ(sum_u64(ex(), u, 42), 42u);
  EXPECT_EQ(reduce_f64(ex(), f, 3.5, kf::exec::SumOp{}), 3.5);
  EXPECT_EQ(reduce_f64(ex(), f, -3.5, kf::exec::MaxOp{}), -3.5);
  EXPECT_EQ(reduce_f64(ex(), f, 9.0, kf::exec::MinOp{}), 9.0);
}

TEST_P(ExecTest, TransformReduceIntoAccumulatesOnTheBackend) {
  // Sizes in decreasing and increasing order, so the reused scratch both shrinks in use and grows.
  DeviceBuffer<double> sum(b(), 0, "sum"), mx(b(), 0, "max");
  sum.assign(std::vector<double>{2.5});
  mx.assign(std::vector<double>{-1e300});
  double want_sum = 2.5, abs_sum = 2.5, want_max = -1e300;
  const std::size_t sizes[] = {1u << 20, 3, 100003, 0, 257, 1};
  for (std::size_t n : sizes) {
    const auto hf = random_f64(n, 23 + static_cast<std::uint32_t>(n));
    DeviceBuffer<double> f(b(), 0, "f");
    f.assign(hf);
    reduce_f64_into(ex(), f, kf::exec::SumOp{}, sum);
    reduce_f64_into(ex(), f, kf::exec::MaxOp{}, mx);
    for (double x : hf) {
      want_sum += x;
      abs_sum += std::fabs(x);
      want_max = std::max(want_max, x);
    }
    // Interleaved host-read reductions use the same scratch; they must not disturb the sums.
    if (n > 0) {
      EXPECT_EQ(reduce_f64(ex(), f, -1e300, kf::exec::MaxOp{}),
                *std::max_element(hf.begin(), hf.end()));
    }
  }
  EXPECT_NEAR(sum.to_host()[0], want_sum, 1e-12 * abs_sum);
  EXPECT_EQ(mx.to_host()[0], want_max);
}

// The one-pass atomic max: exact against the host's max for float and double, accumulating onto
// the value already there (and keeping it when larger), every element visited once.
template <typename T>
void check_max_into(const Exec& ex, Backend b) {
  DeviceBuffer<T> acc(b, 0, "acc");
  acc.assign(std::vector<T>{T(0.25)});
  T want = T(0.25);
  for (std::size_t n : {std::size_t(1), std::size_t(255), std::size_t(257), std::size_t(100003),
                        std::size_t(1) << 20, std::size_t(0), std::size_t(3)}) {
    const auto hd = random_f64(n, 41 + static_cast<std::uint32_t>(n));
    std::vector<T> hv(hd.begin(), hd.end());
    DeviceBuffer<T> v(b, 0, "v"), out(b, n, "out");
    v.assign(hv);
    out.poison();
    max_abs_into(ex, v, out, acc);
    for (T x : hv)
      want = std::max(want, std::fabs(x));
    EXPECT_EQ(out.to_host(), hv) << "n = " << n;
    EXPECT_EQ(acc.to_host()[0], want) << "n = " << n;
  }
  acc.assign(std::vector<T>{T(1e30)}); // larger than every value: stays
  DeviceBuffer<T> v(b, 0, "v"), out(b, 1000, "out");
  v.assign(std::vector<T>(1000, T(-3)));
  max_abs_into(ex, v, out, acc);
  EXPECT_EQ(acc.to_host()[0], T(1e30));
}

TEST_P(ExecTest, MaxIntoIsExactAndVisitsEveryElement) {
  check_max_into<float>(ex(), b());
  check_max_into<double>(ex(), b());
}

/// max_into_each over (|v[i]|, |v[i]| / 2, i-th of three spikes): three maxima in one pass.
template <typename T>
struct ThreeMaxima {
  const T* v;
  KF_HD kf::exec::Maxima<T, 3> operator()(std::size_t i) const {
    const T a = v[i] < T(0) ? -v[i] : v[i];
    return {{a, a / T(2), i % 3 == 2 ? T(i) : T(0)}};
  }
};

// max_into_each: each of K maxima exact against the host, accumulated onto what is there.
template <typename T>
void check_max_into_each(const Exec& ex, Backend b) {
  DeviceBuffer<T> acc(b, 0, "acc");
  acc.assign(std::vector<T>{T(0.25), T(1e30), T(0)});
  std::vector<T> want{T(0.25), T(1e30), T(0)};
  // Up to several elements a GPU thread (the kernel strides over more than one grid).
  for (std::size_t n : {std::size_t(1), std::size_t(257), std::size_t(100003),
                        (std::size_t(1) << 21) + 7, std::size_t(0)}) {
    const auto hd = random_f64(n, 53 + static_cast<std::uint32_t>(n));
    std::vector<T> hv(hd.begin(), hd.end());
    DeviceBuffer<T> v(b, 0, "v");
    v.assign(hv);
    kf::exec::max_into_each<T, 3>(ex, n, ThreeMaxima<T>{v.data()}, acc.data(), "test.each");
    for (std::size_t i = 0; i < n; ++i) {
      want[0] = std::max(want[0], std::fabs(hv[i]));
      want[1] = std::max(want[1], std::fabs(hv[i]) / T(2));
      if (i % 3 == 2)
        want[2] = std::max(want[2], T(i));
    }
    EXPECT_EQ(acc.to_host(), want) << "n = " << n;
  }
}

TEST_P(ExecTest, MaxIntoEachIsExactPerValue) {
  check_max_into_each<float>(ex(), b());
  check_max_into_each<double>(ex(), b());
}

// A pending read returns what the buffer held when it was started, even though work queued
// after the start overwrites the buffer; the host can queue that work before it waits.
TEST_P(ExecTest, PendingReadSeesTheBufferAsItWasWhenStarted) {
  DeviceBuffer<double> buf(b(), 3, "buf");
  kf::exec::PendingRead<double> read(b(), 3, "test.read");
  EXPECT_FALSE(read.pending());
  EXPECT_THROW(read.wait(), kf::Error);
  for (double value : {1.5, -2.25}) {
    set_all(ex(), buf, value);
    read.start(buf.data());
    EXPECT_TRUE(read.pending());
    set_all(ex(), buf, 99.0); // queued behind the copy
    const auto got = read.wait();
    ASSERT_EQ(got.size(), 3u);
    for (double g : got)
      EXPECT_EQ(g, value);
    EXPECT_FALSE(read.pending());
    EXPECT_EQ(buf.to_host(), std::vector<double>(3, 99.0));
  }
  read.start(buf.data(), 1);
  EXPECT_EQ(read.wait().size(), 1u);
  EXPECT_THROW(read.start(buf.data(), 4), kf::Error); // more than the slot holds
}

// The fluid's step planned on the backend, against the rule written out here in double:
// dt = min(limit, cfl h / (c + vmax), F sqrt(h / amax)), landed on the remainder; dt 0 (and
// not landing) when the bounds are not finite or the stable step is below dt_min. Bit for bit.
TEST_P(ExecTest, StepPlanIsTheHostRuleBitForBit) {
  const kf::FluidStepRule rule = test_step_rule();
  const float inf = std::numeric_limits<float>::infinity();
  const float nan = std::numeric_limits<float>::quiet_NaN();
  struct Case {
    float v2, a2;
    double remaining;
  };
  const Case cases[] = {{0.f, 0.f, 1.0},     {27.5f, 3.1e4f, 1.0}, {1e-8f, 9.81f * 9.81f, 0.01},
                        {4.f, 96.f, 3.0e-5}, {4.f, 96.f, 4.5e-5},  {4.f, 96.f, 1.0e-6},
                        {25.f, 1e20f, 1.0},  {inf, 1.f, 1.0},      {1.f, nan, 1.0},
                        {1e30f, 1e30f, 1.0}, {0.f, 0.f, 0.0}};
  for (const Case& c : cases) {
    const double vmax = std::sqrt(double(c.v2)), amax = std::sqrt(double(c.a2));
    double stable = std::min(rule.limit, rule.cfl * rule.h / (rule.sound + vmax));
    if (amax > 0)
      stable = std::min(stable, rule.force_factor * std::sqrt(rule.h / amax));
    const bool finite = std::isfinite(double(c.v2)) && std::isfinite(double(c.a2));
    const bool ok = finite && !(stable < rule.dt_min);
    double dt = stable;
    bool lands = false;
    if (c.remaining <= stable * (1 + 1e-9)) {
      dt = c.remaining;
      lands = true;
    } else if (c.remaining < 2 * stable) {
      dt = 0.5 * c.remaining;
    }
    const kf::StepPlan<float> p = plan_on(ex(), rule, {c.v2, c.a2}, c.remaining);
    const std::string what = "v2 " + std::to_string(c.v2) + ", a2 " + std::to_string(c.a2) +
                             ", remaining " + std::to_string(c.remaining);
    EXPECT_EQ(p.finite != 0, finite) << what;
    EXPECT_EQ(p.dt, ok ? dt : 0.0) << what;
    EXPECT_EQ(p.lands != 0, ok && lands) << what;
    if (finite) {
      EXPECT_EQ(p.stable_dt, stable) << what;
    }
    EXPECT_EQ(std::memcmp(&p.bounds, &c, sizeof(p.bounds)), 0) << what; // v2, a2 as given
  }
}

// The bounds a job all-reduces by their maxima (N ranks, NCCL): NaN read as +infinity (a maximum
// must not lose a blown-up rank), every other value, infinity included, as it is; and the plan
// from them finds them not finite.
TEST_P(ExecTest, BoundsForJobMaxReadNanAsInfinity) {
  const float inf = std::numeric_limits<float>::infinity();
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const kf::MotionBounds<float> in[] = {{0.f, 0.f}, {27.5f, 3.1e4f}, {nan, 1.f},   {1.f, nan},
                                        {nan, nan}, {inf, 2.f},      {-0.f, 1e30f}};
  DeviceBuffer<kf::MotionBounds<float>> from(b(), 0, "bounds"), to(b(), 1, "job bounds");
  for (const auto& c : in) {
    from.assign(std::vector<kf::MotionBounds<float>>{c});
    to.poison();
    kf::bounds_for_job_max(ex(), from.data(), to.data());
    const auto got = to.to_host()[0];
    const float v2 = std::isnan(c.v2) ? inf : c.v2, a2 = std::isnan(c.a2) ? inf : c.a2;
    EXPECT_EQ(std::memcmp(&got.v2, &v2, sizeof v2), 0) << c.v2 << " -> " << got.v2;
    EXPECT_EQ(std::memcmp(&got.a2, &a2, sizeof a2), 0) << c.a2 << " -> " << got.a2;
    const bool finite = std::isfinite(c.v2) && std::isfinite(c.a2);
    EXPECT_EQ(plan_on(ex(), test_step_rule(), got, 1.0).finite != 0, finite)
        << c.v2 << ", " << c.a2;
  }
}

// transform_reduce_to writes what transform_reduce returns (the same tree), init included, and
// init alone for no elements.
TEST_P(ExecTest, TransformReduceToWritesTheReduction) {
  DeviceBuffer<double> out(b(), 1, "out");
  for (std::size_t n : {std::size_t(0), std::size_t(1), std::size_t(257), std::size_t(100003)}) {
    const auto hf = random_f64(n, 77 + static_cast<std::uint32_t>(n));
    DeviceBuffer<double> f(b(), 0, "f");
    f.assign(hf);
    EXPECT_EQ(reduce_f64_to(ex(), f, out), reduce_f64(ex(), f, 1.5, kf::exec::SumOp{}))
        << "n = " << n;
  }
}

// for_each_lanes: every element once, its loop split over G lanes and summed back exactly, for
// sizes around the block (128 threads = 128 / G elements) and G from 1 to 32.
template <unsigned G>
void check_lanes(const Exec& ex, Backend b) {
  for (std::size_t n : {std::size_t(1), std::size_t(31), std::size_t(32), std::size_t(33),
                        std::size_t(1000), std::size_t(100003)}) {
    DeviceBuffer<double> out(b, n, "out");
    DeviceBuffer<std::uint32_t> visits(b, n, "visits");
    out.poison();
    visits.poison();
    lane_sums<G>(ex, out, visits);
    const auto o = out.to_host();
    const auto v = visits.to_host();
    for (std::size_t i = 0; i < n; ++i) {
      const std::size_t m = i % 37;
      const std::size_t want = m * i + (m > 0 ? m * (m - 1) / 2 : 0); // sum of i + k, k < m
      ASSERT_EQ(o[i], double(want)) << "G = " << G << ", n = " << n << ", i = " << i;
      ASSERT_EQ(v[i], m) << "G = " << G << ", n = " << n << ", i = " << i;
    }
  }
}

TEST_P(ExecTest, ForEachLanesSplitsAndSumsEveryElement) {
  check_lanes<1>(ex(), b());
  check_lanes<4>(ex(), b());
  check_lanes<8>(ex(), b());
  check_lanes<32>(ex(), b());
}

TEST_P(ExecTest, ForEachChunkCoversEveryElementAndAnswersGroupQueries) {
  check_chunks<8>(ex(), b());
  check_chunks<32>(ex(), b());
}

TEST_P(ExecTest, TransformReduceIsDeterministic) {
  const auto hf = random_f64(300001, 5);
  DeviceBuffer<double> f(b(), 0, "f");
  f.assign(hf);
  const double first = reduce_f64(ex(), f, 0.0, kf::exec::SumOp{});
  for (int rep = 0; rep < 3; ++rep)
    EXPECT_EQ(reduce_f64(ex(), f, 0.0, kf::exec::SumOp{}), first);
}

TEST_P(ExecTest, SortByKeyIsStableSort) {
  for (int key_bits : {1, 8, 17, 24, 32}) {
    for (std::size_t n : {std::size_t{0}, std::size_t{1}, std::size_t{1000}, std::size_t{100003}}) {
      auto hk = random_u32(n, 0xFFFFFFFFu, 100u + static_cast<std::uint32_t>(key_bits));
      for (auto& k : hk)
        k &= key_mask(key_bits);
      const auto hv = random_u32(n, 0xFFFFFFFFu, 200u + static_cast<std::uint32_t>(n));

      std::vector<std::pair<std::uint32_t, std::uint32_t>> want(n);
      for (std::size_t i = 0; i < n; ++i)
        want[i] = {hk[i], hv[i]};
      std::stable_sort(want.begin(), want.end(),
                       [](const auto& a, const auto& c) { return a.first < c.first; });

      DeviceBuffer<std::uint32_t> keys(b(), 0, "keys"), values(b(), 0, "values");
      keys.assign(hk);
      values.assign(hv);
      kf::exec::sort_by_key(ex(), keys, values, key_bits, "test.sort");
      const auto gk = keys.to_host(), gv = values.to_host();
      ASSERT_EQ(gk.size(), n);
      ASSERT_EQ(gv.size(), n);
      std::size_t bad = 0;
      for (std::size_t i = 0; i < n; ++i)
        bad += gk[i] != want[i].first || gv[i] != want[i].second;
      EXPECT_EQ(bad, 0u) << "key_bits=" << key_bits << " n=" << n;
    }
  }
}

TEST_P(ExecTest, SortByKeyRejectsMismatchedSizes) {
  DeviceBuffer<std::uint32_t> keys(b(), 10, "keys"), values(b(), 9, "values");
  EXPECT_THROW(kf::exec::sort_by_key(ex(), keys, values, 8, "test.sort"), kf::Error);
}

TEST_P(ExecTest, ExclusiveScanMatchesStd) {
  for (std::size_t n : {std::size_t{0}, std::size_t{1}, std::size_t{1000}, std::size_t{100003},
                        std::size_t{1} << 20}) {
    // Small counts (the usual use: cell occupancies) and large values whose sum passes 2^32.
    for (std::uint32_t max : {1000u, 0x7FFFFFFFu}) {
      const auto h = random_u32(n, max, 300u + static_cast<std::uint32_t>(n));
      std::vector<std::uint32_t> want(n);
      std::exclusive_scan(h.begin(), h.end(), want.begin(), std::uint32_t{0});
      std::uint64_t want_total = 0;
      for (auto x : h)
        want_total += x;

      DeviceBuffer<std::uint32_t> in(b(), 0, "in"), out(b(), n, "out");
      in.assign(h);
      out.poison();
      EXPECT_EQ(kf::exec::exclusive_scan(ex(), in, out, "test.scan"), want_total)
          << "n=" << n << " max=" << max;
      EXPECT_EQ(out.to_host(), want) << "n=" << n << " max=" << max;
      EXPECT_EQ(in.to_host(), h) << "input modified, n=" << n;

      // In place: out aliases in.
      EXPECT_EQ(kf::exec::exclusive_scan(ex(), in, in, "test.scan_inplace"), want_total)
          << "n=" << n << " max=" << max;
      EXPECT_EQ(in.to_host(), want) << "in place, n=" << n << " max=" << max;
    }
  }
}

TEST_P(ExecTest, ExclusiveScanOnDeviceLeavesItsTotalThereOrOut) {
  for (std::size_t n : {std::size_t{0}, std::size_t{1}, std::size_t{1000}, std::size_t{100003}}) {
    const auto h = random_u32(n, 1, 500u + static_cast<std::uint32_t>(n)); // flags, as its use
    std::vector<std::uint32_t> want(n);
    std::exclusive_scan(h.begin(), h.end(), want.begin(), std::uint32_t{0});
    const std::uint32_t want_total = std::accumulate(h.begin(), h.end(), std::uint32_t{0});
    DeviceBuffer<std::uint32_t> in(b(), 0, "in"), out(b(), n, "out"), total(b(), 1, "total");
    in.assign(h);
    for (bool with_total : {true, false}) {
      out.poison();
      total.poison();
      const std::uint32_t poison = total.to_host()[0];
      kf::exec::exclusive_scan_on_device(ex(), in, out, with_total ? total.data() : nullptr,
                                         "test.scan_on_device");
      EXPECT_EQ(out.to_host(), want) << "n=" << n << " with_total=" << with_total;
      // Without one the total's buffer stays as it was: nothing written past the scan.
      EXPECT_EQ(total.to_host()[0], with_total ? want_total : poison)
          << "n=" << n << " with_total=" << with_total;
    }
    EXPECT_EQ(in.to_host(), h) << "input modified, n=" << n;
  }
}

TEST_P(ExecTest, FlaggedIndicesCompactsInOrder) {
  for (std::size_t n : kSizes) {
    const auto bits = random_u32(n, 1, 31 + static_cast<std::uint32_t>(n));
    DeviceBuffer<std::uint32_t> flags(b(), 0, "flags"), offsets(b(), 0, "offsets"),
        out(b(), 3, "out");
    flags.assign(bits);
    out.poison();
    const std::size_t k = kf::exec::flagged_indices(ex(), flags, offsets, out, "test.flagged");
    std::vector<std::uint32_t> want;
    for (std::size_t i = 0; i < n; ++i)
      if (bits[i])
        want.push_back(static_cast<std::uint32_t>(i));
    ASSERT_EQ(k, want.size()) << "n=" << n;
    EXPECT_EQ(out.to_host(), want) << "n=" << n;
  }
}

TEST_P(ExecTest, GatherPermutes) {
  for (std::size_t n : {std::size_t{1}, std::size_t{1000}, std::size_t{100003}}) {
    std::vector<std::uint32_t> perm(n);
    std::iota(perm.begin(), perm.end(), 0u);
    std::shuffle(perm.begin(), perm.end(), std::mt19937(static_cast<std::uint32_t>(n)));
    const auto src = random_f64(n, 400);

    DeviceBuffer<std::uint32_t> p(b(), 0, "perm");
    DeviceBuffer<double> s(b(), 0, "src"), d(b(), n, "dst");
    p.assign(perm);
    s.assign(src);
    d.poison();
    kf::exec::gather(ex(), p, s, d, "test.gather");
    const auto got = d.to_host();
    std::size_t bad = 0;
    for (std::size_t i = 0; i < n; ++i)
      bad += got[i] != src[perm[i]];
    EXPECT_EQ(bad, 0u) << "n=" << n;
  }
  DeviceBuffer<std::uint32_t> p(b(), 4, "perm");
  DeviceBuffer<double> s(b(), 4, "src"), d(b(), 3, "dst");
  EXPECT_THROW(kf::exec::gather(ex(), p, s, d, "test.gather"), kf::Error);
}

// The first k elements, copied to the host without touching the (uninitialised) rest, so the test
// stays clean under compute-sanitizer --tool initcheck.
std::vector<std::uint32_t> prefix(const DeviceBuffer<std::uint32_t>& buf, std::size_t k) {
  DeviceBuffer<std::uint32_t> h(Backend::Cpu, k, "prefix");
  h.copy_from(buf, k);
  return h.to_host();
}

TEST_P(ExecTest, DeviceBufferResizeKeepsLeadingContents) {
  const auto h = random_u32(1000, 0xFFFFFFFFu, 500);
  DeviceBuffer<std::uint32_t> buf(b(), 0, "buf");
  EXPECT_TRUE(buf.empty());
  EXPECT_TRUE(buf.to_host().empty());
  buf.assign(h);
  EXPECT_EQ(buf.to_host(), h);

  buf.resize(5000); // reallocates
  EXPECT_EQ(buf.size(), 5000u);
  EXPECT_EQ(prefix(buf, 1000), h);

  buf.resize(10); // shrinks in place
  EXPECT_EQ(buf.to_host(), std::vector<std::uint32_t>(h.begin(), h.begin() + 10));

  buf.resize(4000); // within capacity: the first 10 must still be there
  EXPECT_EQ(buf.size(), 4000u);
  EXPECT_EQ(prefix(buf, 10), std::vector<std::uint32_t>(h.begin(), h.begin() + 10));
  EXPECT_GE(buf.capacity_bytes(), 5000 * sizeof(std::uint32_t));
}

TEST_P(ExecTest, DeviceBufferGrowthDiscardingHoldsOnlyTheNewRoom) {
  DeviceBuffer<std::uint32_t> buf(b(), 0, "buf");
  buf.assign(random_u32(1000, 0xFFFFFFFFu, 502));
  const std::size_t before = kf::exec::held_bytes(b()).now;
  kf::exec::reset_peak_bytes(b());
  buf.reserve_discarding(800); // within its room: nothing moves
  EXPECT_EQ(kf::exec::held_bytes(b()).peak, before);
  EXPECT_EQ(buf.size(), 1000u);
  buf.reserve_discarding(4000);
  // The old room was freed before the new was taken: the peak is the ledger's less the old
  // room plus the new (with reserve: both at once).
  const std::size_t old_room = 1000 * sizeof(std::uint32_t);
  EXPECT_EQ(kf::exec::held_bytes(b()).peak, before - old_room + 4000 * sizeof(std::uint32_t));
  EXPECT_EQ(buf.capacity(), 4000u);
  EXPECT_EQ(buf.size(), 0u);        // the contents are gone
  buf.resize_snug_discarding(3000); // within: the room stays
  EXPECT_EQ(buf.capacity(), 4000u);
  EXPECT_EQ(buf.size(), 3000u);
  buf.resize_snug_discarding(8000); // grows by a sixteenth more, as resize_snug
  EXPECT_EQ(buf.capacity(), 8500u);
  EXPECT_EQ(buf.size(), 8000u);
  const std::vector<std::uint32_t> h = random_u32(8000, 0xFFFFFFFFu, 503);
  buf.assign(h); // and usable
  EXPECT_EQ(buf.to_host(), h);
}

TEST_P(ExecTest, PeakByLabelIsWhatWasHeldAtThePeak) {
  using kf::exec::peak_by_label;
  const auto bytes_of = [](const std::vector<kf::exec::LabelledBytes>& by, const char* label) {
    for (const auto& l : by)
      if (l.label == label)
        return l.bytes;
    return std::size_t(0);
  };
  kf::exec::reset_peak_bytes(b());
  DeviceBuffer<std::uint32_t> a(b(), 1000, "test.peak_a");
  DeviceBuffer<std::uint32_t> c(b(), 2000, "test.peak_c");
  a = DeviceBuffer<std::uint32_t>(b(), 0, "test.peak_a"); // a's room freed below the peak
  DeviceBuffer<std::uint32_t> d(b(), 500, "test.peak_d"); // under it: not at the peak
  auto by = peak_by_label(b());
  EXPECT_EQ(bytes_of(by, "test.peak_a"), 4000u);
  EXPECT_EQ(bytes_of(by, "test.peak_c"), 8000u);
  EXPECT_EQ(bytes_of(by, "test.peak_d"), 0u);
  DeviceBuffer<std::uint32_t> e(b(), 5000, "test.peak_a"); // a new peak: a's label again
  by = peak_by_label(b());
  EXPECT_EQ(bytes_of(by, "test.peak_a"), 20000u);
  EXPECT_EQ(bytes_of(by, "test.peak_c"), 8000u);
  EXPECT_EQ(bytes_of(by, "test.peak_d"), 2000u);
  // The labels' bytes sum to the ledger's peak, largest first.
  std::size_t sum = 0;
  for (std::size_t k = 0; k < by.size(); ++k) {
    sum += by[k].bytes;
    if (k > 0) {
      EXPECT_GE(by[k - 1].bytes, by[k].bytes);
    }
  }
  EXPECT_EQ(sum, kf::exec::held_bytes(b()).peak);
}

TEST_P(ExecTest, DeviceBufferShrinkToFitKeepsContentsAndFreesTheRest) {
  const auto h = random_u32(4000, 0xFFFFFFFFu, 501);
  DeviceBuffer<std::uint32_t> buf(b(), 0, "buf");
  buf.assign(h);
  buf.resize(300); // a rank's share of a whole set: the room stays held
  const std::size_t held = kf::exec::held_bytes(b()).now;
  buf.shrink_to_fit();
  EXPECT_EQ(buf.capacity(), 300u);
  // The ledger (the backend's, every buffer of the process) lost exactly the spare room.
  EXPECT_EQ(held - kf::exec::held_bytes(b()).now, 3700 * sizeof(std::uint32_t));
  EXPECT_EQ(buf.to_host(), std::vector<std::uint32_t>(h.begin(), h.begin() + 300));
  buf.resize(0);
  buf.shrink_to_fit(); // nothing left: nothing held
  EXPECT_EQ(buf.capacity(), 0u);
  EXPECT_EQ(buf.data(), nullptr);
  buf.assign(h); // and usable again
  EXPECT_EQ(buf.to_host(), h);
}

TEST_P(ExecTest, DeviceBufferCopiesAndMoves) {
  const auto h = random_f64(777, 600);
  DeviceBuffer<double> a(b(), 0, "a");
  a.assign(h);
  // Copy to the same backend and to the host backend, with offsets.
  DeviceBuffer<double> c(b(), 777, "c"), host(Backend::Cpu, 777, "host");
  c.poison();
  c.copy_from(a, 777);
  EXPECT_EQ(c.to_host(), h);
  host.poison();
  host.copy_from(a, 700, 77, 0);
  for (std::size_t i = 0; i < 700; ++i)
    ASSERT_EQ(host.data()[77 + i], h[i]);
  // And back from the host into this backend.
  DeviceBuffer<double> back(b(), 777, "back");
  back.poison();
  back.copy_from(host, 700, 0, 77);
  const auto gb = back.to_host();
  EXPECT_TRUE(std::equal(h.begin(), h.begin() + 700, gb.begin()));

  DeviceBuffer<double> moved(std::move(a));
  EXPECT_EQ(moved.backend(), b());
  EXPECT_EQ(moved.to_host(), h);
  EXPECT_EQ(a.size(), 0u); // NOLINT(bugprone-use-after-move): moved-from is empty by contract
}

// host_value(i) reads element i, and only it: the elements around it may be unwritten (a run
// without their phase); an index past the size is an error naming the buffer.
TEST_P(ExecTest, DeviceBufferHostValueIsTheElement) {
  const auto h = random_f64(5, 31);
  DeviceBuffer<double> a(b(), 0, "test.values");
  a.assign(h);
  for (std::size_t i = 0; i < h.size(); ++i)
    EXPECT_EQ(a.host_value(i), h[i]) << i;
  try {
    (void)a.host_value(5);
    ADD_FAILURE() << "no error for element 5 of 5";
  } catch (const kf::Error& e) {
    EXPECT_NE(std::string(e.what()).find("test.values: element 5 of 5"), std::string::npos)
        << e.what();
  }
}

// KF_POISON_ALLOCATIONS=1 (ctest's "_poisoned" runs): a fresh buffer holds 0xFF bytes, NaN in
// every float, so that the tests run under it see any value read before it was written.
TEST_P(ExecTest, AFreshBufferIsPoisonedWhenAsked) {
  const char* v = std::getenv("KF_POISON_ALLOCATIONS");
  if (!v || v[0] != '1')
    GTEST_SKIP() << "KF_POISON_ALLOCATIONS is not 1 (test_exec_K_poisoned sets it)";
  DeviceBuffer<float> f(b(), 1000, "test.fresh");
  for (float x : f.to_host())
    ASSERT_TRUE(std::isnan(x));
  DeviceBuffer<std::uint32_t> u(b(), 0, "test.grown");
  u.assign(std::vector<std::uint32_t>(10, 7u));
  u.resize(5000); // the growth's new room, past the ten copied
  const auto h = u.to_host();
  for (std::size_t i = 10; i < h.size(); ++i)
    ASSERT_EQ(h[i], 0xFFFFFFFFu) << i;
}

INSTANTIATE_TEST_SUITE_P(Backends, ExecTest, ::testing::Values(Backend::Cpu, Backend::Cuda),
                         [](const ::testing::TestParamInfo<Backend>& info) {
                           return info.param == Backend::Cpu ? std::string("Cpu")
                                                             : std::string("Cuda");
                         });

// ---- CPU and CUDA agree ------------------------------------------------------------------------

class ExecCpuVsCuda : public ::testing::Test {
protected:
  void SetUp() override {
    if (!kf::exec::cuda_available())
      GTEST_SKIP() << "no CUDA device";
  }
  const Exec cpu{Backend::Cpu};
  const Exec gpu{Backend::Cuda};
};

TEST_F(ExecCpuVsCuda, SameInputsSameOutputs) {
  const std::size_t n = 100003;
  const auto keys = random_u32(n, (1u << 20) - 1, 700);
  const auto vals = random_u32(n, 0xFFFFFFFFu, 701);
  const auto counts = random_u32(n, 64, 702);
  const auto data = random_f64(n, 703);

  // sort_by_key
  DeviceBuffer<std::uint32_t> kc(Backend::Cpu, 0, "kc"), vc(Backend::Cpu, 0, "vc");
  DeviceBuffer<std::uint32_t> kg(Backend::Cuda, 0, "kg"), vg(Backend::Cuda, 0, "vg");
  kc.assign(keys), vc.assign(vals), kg.assign(keys), vg.assign(vals);
  kf::exec::sort_by_key(cpu, kc, vc, 20, "test.sort");
  kf::exec::sort_by_key(gpu, kg, vg, 20, "test.sort");
  EXPECT_EQ(kc.to_host(), kg.to_host());
  EXPECT_EQ(vc.to_host(), vg.to_host());

  // exclusive_scan
  DeviceBuffer<std::uint32_t> ic(Backend::Cpu, 0, "ic"), oc(Backend::Cpu, n, "oc");
  DeviceBuffer<std::uint32_t> ig(Backend::Cuda, 0, "ig"), og(Backend::Cuda, n, "og");
  ic.assign(counts), ig.assign(counts);
  EXPECT_EQ(kf::exec::exclusive_scan(cpu, ic, oc, "test.scan"),
            kf::exec::exclusive_scan(gpu, ig, og, "test.scan"));
  EXPECT_EQ(oc.to_host(), og.to_host());

  // gather by the sorted values' order (a permutation of 0..n)
  std::vector<std::uint32_t> perm(n);
  std::iota(perm.begin(), perm.end(), 0u);
  std::shuffle(perm.begin(), perm.end(), std::mt19937(704));
  DeviceBuffer<std::uint32_t> pc(Backend::Cpu, 0, "pc"), pg(Backend::Cuda, 0, "pg");
  pc.assign(perm), pg.assign(perm);
  DeviceBuffer<double> sc(Backend::Cpu, 0, "sc"), sg(Backend::Cuda, 0, "sg");
  sc.assign(data), sg.assign(data);
  DeviceBuffer<double> dc(Backend::Cpu, n, "dc"), dg(Backend::Cuda, n, "dg");
  kf::exec::gather(cpu, pc, sc, dc, "test.gather");
  kf::exec::gather(gpu, pg, sg, dg, "test.gather");
  EXPECT_EQ(dc.to_host(), dg.to_host());

  // for_each
  DeviceBuffer<double> fc(Backend::Cpu, n, "fc"), fg(Backend::Cuda, n, "fg");
  DeviceBuffer<std::uint32_t> uc(Backend::Cpu, n, "uc"), ug(Backend::Cuda, n, "ug");
  mix(cpu, sc, fc, uc);
  mix(gpu, sg, fg, ug);
  EXPECT_EQ(fc.to_host(), fg.to_host());
  EXPECT_EQ(uc.to_host(), ug.to_host());

  // transform_reduce: exact for integers and max/min; sums of doubles differ only in rounding.
  EXPECT_EQ(sum_u64(cpu, kc, 1), sum_u64(gpu, kg, 1));
  EXPECT_EQ(reduce_f64(cpu, sc, -1e300, kf::exec::MaxOp{}),
            reduce_f64(gpu, sg, -1e300, kf::exec::MaxOp{}));
  EXPECT_EQ(reduce_f64(cpu, sc, 1e300, kf::exec::MinOp{}),
            reduce_f64(gpu, sg, 1e300, kf::exec::MinOp{}));
  double abs_sum = 0;
  for (double x : data)
    abs_sum += std::fabs(x);
  EXPECT_NEAR(reduce_f64(cpu, sc, 0.0, kf::exec::SumOp{}),
              reduce_f64(gpu, sg, 0.0, kf::exec::SumOp{}), 1e-12 * abs_sum);
}

// The CPU's side stream is inert: launches stay where they were and run at once.
TEST(ExecSideStream, OnTheCpuItChangesNothing) {
  kf::exec::SideStream side(Backend::Cpu);
  EXPECT_FALSE(side.active());
  side.fork();
  const kf::exec::OnSideStream beside(side);
  EXPECT_EQ(kf::exec::launch_stream(), nullptr);
  DeviceBuffer<std::uint32_t> out(Backend::Cpu, 1000, "out");
  out.poison();
  write_index(Exec{Backend::Cpu}, out);
  EXPECT_EQ(out.to_host()[999], 3u * 999u + 1u);
  side.join();
}

// A rank's interior pass runs on the side stream beside its border's (RankExchange): fork must
// order it after the legacy default stream's earlier work, join the legacy stream's later work
// after it. Three passes, each reading the last one's output (the first two slow, on a few SMs),
// against the CPU's; poisoned outputs show a pass that ran early. Without the fork the side's
// pass reads the poison at once, without the join the last pass runs while the side's still
// does (both checked by removing them: every element wrong).
TEST(ExecSideStream, ForkAndJoinOrderItsWorkWithTheDefaultStream) {
  if (!kf::exec::cuda_available())
    GTEST_SKIP() << "no CUDA device";
  const std::size_t n = 256;
  std::vector<std::uint32_t> want;
  {
    const Exec cpu{Backend::Cpu};
    DeviceBuffer<std::uint32_t> a(Backend::Cpu, n, "a"), b(Backend::Cpu, n, "b"),
        c(Backend::Cpu, n, "c");
    mix_slowly(cpu, nullptr, a);
    mix_slowly(cpu, a.data(), b);
    xor_with(cpu, b, c, 0x5A5A5A5Au);
    want = c.to_host();
  }
  const Exec gpu{Backend::Cuda};
  kf::exec::SideStream side(Backend::Cuda);
  ASSERT_TRUE(side.active());
  for (int round = 0; round < 2; ++round) {
    DeviceBuffer<std::uint32_t> a(Backend::Cuda, n, "a"), b(Backend::Cuda, n, "b"),
        c(Backend::Cuda, n, "c");
    a.poison();
    b.poison();
    c.poison();
    mix_slowly(gpu, nullptr, a); // the legacy default stream
    side.fork();
    {
      const kf::exec::OnSideStream beside(side);
      EXPECT_EQ(kf::exec::launch_stream(), side.stream());
      mix_slowly(gpu, a.data(), b);
    }
    EXPECT_EQ(kf::exec::launch_stream(), nullptr);
    side.join();
    xor_with(gpu, b, c, 0x5A5A5A5Au); // the legacy default stream again
    const auto got = c.to_host();
    std::size_t bad = 0;
    for (std::size_t i = 0; i < n; ++i)
      bad += got[i] != want[i];
    EXPECT_EQ(bad, 0u) << "round " << round;
  }
}

// The scratch slots' users are ordered by the legacy default stream alone: one on the side
// stream is refused, not raced.
TEST(ExecSideStream, RefusesAScratchUser) {
  if (!kf::exec::cuda_available())
    GTEST_SKIP() << "no CUDA device";
  const Exec gpu{Backend::Cuda};
  DeviceBuffer<std::uint32_t> in(Backend::Cuda, 1000, "in"), out(Backend::Cuda, 1000, "out");
  write_index(gpu, in);
  kf::exec::SideStream side(Backend::Cuda);
  {
    const kf::exec::OnSideStream beside(side);
    try {
      (void)kf::exec::exclusive_scan(gpu, in, out, "test.scan");
      FAIL() << "a scan ran on the side stream";
    } catch (const kf::Error& e) {
      EXPECT_NE(std::string(e.what()).find("side stream"), std::string::npos) << e.what();
    }
  }
  // Outside the scope it runs.
  EXPECT_EQ(kf::exec::exclusive_scan(gpu, in, out, "test.scan"), 1000u * 999u / 2u * 3u + 1000u);
}

#if defined(KF_WITH_CUDA) && defined(__CUDACC__)
// Error text needs no device: cudaGetErrorString is a table lookup.
TEST(ExecCudaErrors, MessagesNameContextAndError) {
  try {
    KF_CUDA(cudaErrorInvalidValue, std::string("copying 12 bytes host->device for 'x'"));
    FAIL() << "KF_CUDA did not throw";
  } catch (const kf::Error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("copying 12 bytes host->device for 'x'"), std::string::npos) << m;
    EXPECT_NE(m.find(cudaGetErrorString(cudaErrorInvalidValue)), std::string::npos) << m;
  }
  EXPECT_THROW(KF_CUDA(cudaErrorInvalidValue), kf::Error);
}

TEST(ExecCudaErrors, OutOfMemoryNamesBytesAndFreeMemory) {
  if (!kf::exec::cuda_available())
    GTEST_SKIP() << "no CUDA device";
  const std::size_t huge = std::size_t{1} << 50; // 1 PiB
  try {
    DeviceBuffer<unsigned char> buf(Backend::Cuda, huge, "test huge buffer");
    FAIL() << "a 1 PiB allocation succeeded";
  } catch (const kf::Error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("test huge buffer"), std::string::npos) << m;
    EXPECT_NE(m.find(std::to_string(huge)), std::string::npos) << m;
    EXPECT_NE(m.find("free"), std::string::npos) << m;
  }
  // The context is still usable afterwards.
  DeviceBuffer<std::uint32_t> small(Backend::Cuda, 256, "small");
  write_index(Exec{Backend::Cuda}, small);
  EXPECT_EQ(small.to_host()[255], 3u * 255u + 1u);
}
#endif

} // namespace
