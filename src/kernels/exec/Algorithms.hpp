#pragma once
// The execution layer: the few parallel primitives every kernel is launched through.
// Templates taking functors are defined here so nvcc instantiates them for the device when the
// including file is compiled as CUDA; on a CPU build the same call runs an OpenMP loop.
#include "core/Error.hpp"
#include "core/HostDevice.hpp"
#include "core/Vec3.hpp"
#include "kernels/exec/Backend.hpp"
#include "kernels/exec/DeviceBuffer.hpp"
#include "kernels/exec/Streams.hpp"

#include <cstddef>
#include <cstdint>
#include <limits>
#include <string>
#include <type_traits>
#include <vector>

#if defined(_OPENMP)
#include <omp.h>
#endif

#if defined(__CUDACC__)
#include "kernels/exec/CudaCheck.hpp"
#include <cub/block/block_reduce.cuh>
#endif

namespace kf::exec {

/// Backend plus a label naming the stage, used in every error message a launch can produce.
struct Exec {
  Backend backend = Backend::Cpu;
};

[[noreturn]] void throw_not_compiled_for_cuda(const char* label);

/// p[i] = value. A named functor, not a device lambda: see the note at GatherBy.
template <typename T>
struct FillWith {
  T* p;
  T value;
  KF_HD KF_INLINE void operator()(std::size_t i) const { p[i] = value; }
};

/// The lanes that share one element in for_each_lanes: lane in [0, size). Lanes split the
/// element's loop (lane, lane + size, ...) and combine with sum(), which every lane of the group
/// must reach (the decisions before it must depend on the element only).
struct Lanes {
  unsigned lane = 0, size = 1;

  /// Sum over the group's lanes, returned to all of them (a butterfly over warp shuffles, in a
  /// fixed order: deterministic; it differs from a sequential sum by rounding).
  template <typename V>
  KF_HD KF_INLINE V sum(V v) const {
    return butterfly(v, [](const V& a, const V& b) { return a + b; });
  }

  /// The lowest lane of the group whose `p` is true, or `size` when none is (all lanes call).
  KF_HD KF_INLINE unsigned first_set(bool p) const {
    const unsigned b = ballot(p);
    return b ? lowest_bit(b) : size;
  }
  /// Whether `p` is true on some lane of the group (all lanes call).
  KF_HD KF_INLINE bool any(bool p) const { return first_set(p) < size; }
  /// Lane `from`'s v, to every lane of the group (all lanes call).
  KF_HD KF_INLINE int broadcast(int v, unsigned from) const {
#if defined(__CUDA_ARCH__)
    return __shfl_sync(group_mask(), v, static_cast<int>(from), static_cast<int>(size));
#else
    (void)from;
    return v;
#endif
  }
  /// Smallest and largest v over the group, to every lane (all lanes call).
  KF_HD KF_INLINE int min(int v) const {
    return butterfly(v, [](int a, int b) { return b < a ? b : a; });
  }
  KF_HD KF_INLINE int max(int v) const {
    return butterfly(v, [](int a, int b) { return a < b ? b : a; });
  }
  /// Component-wise smallest and largest v over the group: the box of the lanes' points.
  template <typename T>
  KF_HD KF_INLINE Vec3<T> min_each(const Vec3<T>& v) const {
    return butterfly(v, [](const Vec3<T>& a, const Vec3<T>& b) {
      return Vec3<T>{kmin(a.x, b.x), kmin(a.y, b.y), kmin(a.z, b.z)};
    });
  }
  template <typename T>
  KF_HD KF_INLINE Vec3<T> max_each(const Vec3<T>& v) const {
    return butterfly(v, [](const Vec3<T>& a, const Vec3<T>& b) {
      return Vec3<T>{kmax(a.x, b.x), kmax(a.y, b.y), kmax(a.z, b.z)};
    });
  }
  /// op (associative, commutative) over the group's lanes, the result on every lane (all lanes
  /// call): a butterfly in a fixed order, deterministic. V: a number or a Vec3.
  template <typename V, typename Op>
  KF_HD KF_INLINE V reduce(V v, Op op) const {
    return butterfly(v, op);
  }
  /// How many of the lanes below this one have their bit set in `bits` (a ballot's result):
  /// where this lane's item goes when the group appends in lane order.
  KF_HD KF_INLINE unsigned count_below(unsigned bits) const {
    return popcount(bits & ((1u << lane) - 1u));
  }
  /// The group's bits of the lanes whose p is true, lane 0 of the group at bit 0 (all lanes
  /// call; one lane on the CPU).
  KF_HD KF_INLINE unsigned ballot(bool p) const {
#if defined(__CUDA_ARCH__)
    const unsigned mask = group_mask();
    return (__ballot_sync(mask, p) & mask) >> ((threadIdx.x & 31u) & ~(size - 1u));
#else
    return p ? 1u : 0u;
#endif
  }

private:
  /// op over the group's lanes in a butterfly of warp shuffles, the result on every lane.
  template <typename V, typename Op>
  KF_HD KF_INLINE V butterfly(V v, Op op) const {
#if defined(__CUDA_ARCH__)
    const unsigned mask = group_mask();
    for (unsigned off = size / 2; off > 0; off /= 2)
      v = op(v, shuffle_xor(mask, v, off));
#else
    (void)op;
#endif
    return v;
  }
#if defined(__CUDA_ARCH__)
  /// This group's lanes within the warp.
  __device__ unsigned group_mask() const {
    const unsigned first = (threadIdx.x & 31u) & ~(size - 1u);
    return (size == 32u ? 0xFFFFFFFFu : ((1u << size) - 1u)) << first;
  }
  template <typename V>
  __device__ static V shuffle_xor(unsigned mask, const V& v, unsigned off) {
    if constexpr (std::is_arithmetic_v<V>) {
      return __shfl_xor_sync(mask, v, static_cast<int>(off));
    } else { // Vec3
      return V{__shfl_xor_sync(mask, v.x, static_cast<int>(off)),
               __shfl_xor_sync(mask, v.y, static_cast<int>(off)),
               __shfl_xor_sync(mask, v.z, static_cast<int>(off))};
    }
  }
#endif
};

/// F::kBlocksPerSm when a functor declares it (0 otherwise): the blocks of a launch it asks to
/// have resident on an SM, which caps its registers (for_each_lanes).
template <typename F, typename = void>
struct BlocksPerSmOf {
  static constexpr unsigned value = 0;
};
template <typename F>
struct BlocksPerSmOf<F, std::void_t<decltype(F::kBlocksPerSm)>> {
  static constexpr unsigned value = F::kBlocksPerSm;
};

#if defined(__CUDACC__)
/// Every kernel of this layer starts here. Launched with programmatic dependent launch (sm_90),
/// a kernel's blocks may be scheduled while the kernel before it in the stream still runs: they
/// wait here until it has finished and its writes are visible, then let the next kernel be
/// scheduled. Without it both instructions return at once.
__device__ KF_INLINE void await_previous_kernel() {
#if defined(__CUDA_ARCH__) && __CUDA_ARCH__ >= 900
  asm volatile("griddepcontrol.wait;" ::: "memory");
  asm volatile("griddepcontrol.launch_dependents;" ::: "memory");
#endif
}

/// kernel<<<grid, block>>>(args...) on launch_stream() (the legacy default stream outside an
/// OnSideStream scope), with programmatic dependent launch when launch_overlap().
template <typename... P, typename... A>
void launch(void (*kernel)(P...), std::size_t grid, unsigned block, const char* label,
            std::size_t n, A&&... args) {
  cudaLaunchConfig_t cfg{};
  cfg.gridDim = dim3(static_cast<unsigned>(grid));
  cfg.blockDim = dim3(block);
  cfg.dynamicSmemBytes = 0;
  cfg.stream = launch_stream();
  cudaLaunchAttribute attr[1];
  attr[0].id = cudaLaunchAttributeProgrammaticStreamSerialization;
  attr[0].val.programmaticStreamSerializationAllowed = 1;
  cfg.attrs = attr;
  cfg.numAttrs = launch_overlap() ? 1 : 0;
  const cudaError_t e = cudaLaunchKernelEx(&cfg, kernel, std::forward<A>(args)...);
  if (e != cudaSuccess)
    throw_launch_error(e, label, n);
}

/// This thread's element and lane of for_each_lanes.
template <unsigned G, typename F>
__device__ KF_INLINE void run_lanes(std::size_t n, const F& f) {
  await_previous_kernel();
  const std::size_t t = static_cast<std::size_t>(blockIdx.x) * blockDim.x + threadIdx.x;
  const std::size_t i = t / G;
  if (i < n) // all G lanes of an element agree
    f(i, Lanes{static_cast<unsigned>(t % G), G});
}
template <unsigned G, typename F>
__global__ void for_each_lanes_kernel(std::size_t n, F f) {
  run_lanes<G>(n, f);
}
/// The same for a functor that asks for a register budget: at least F::kBlocksPerSm blocks of
/// Block threads resident on an SM (ptxas then caps the registers a thread may use).
template <unsigned G, unsigned Block, unsigned MinBlocks, typename F>
__global__ void __launch_bounds__(Block, MinBlocks)
    for_each_lanes_bounded_kernel(std::size_t n, F f) {
  run_lanes<G>(n, f);
}
#endif

/// Calls f(i, lanes) for i in [0, n) with G lanes (threads) per element on the GPU, one on the
/// CPU: for gathers whose elements are few (tens of thousands of knit points fill a fraction of
/// a GPU's threads) and whose loops are long enough to split. G: 1, 2, 4, 8, 16 or 32; Block:
/// threads per CUDA block, a multiple of 32.
template <unsigned G, unsigned Block = 128, typename F>
void for_each_lanes(const Exec& ex, std::size_t n, const F& f, const char* label) {
  static_assert(G >= 1 && G <= 32 && (G & (G - 1)) == 0, "for_each_lanes: G a power of 2 <= 32");
  if (n == 0)
    return;
  if (ex.backend == Backend::Cuda) {
#if defined(__CUDACC__)
    const std::size_t threads = n * G;
    const std::size_t grid = (threads + Block - 1) / Block;
    KernelTimeScope timed(label);
    constexpr unsigned kMin = BlocksPerSmOf<F>::value;
    if constexpr (kMin > 0)
      launch(for_each_lanes_bounded_kernel<G, Block, kMin, F>, grid, Block, label, n, n, f);
    else
      launch(for_each_lanes_kernel<G, F>, grid, Block, label, n, n, f);
    KF_CHECK_LAUNCH(label, n);
#else
    throw_not_compiled_for_cuda(label);
#endif
  } else {
    const std::int64_t m = static_cast<std::int64_t>(n);
#pragma omp parallel for schedule(static)
    for (std::int64_t i = 0; i < m; ++i)
      f(static_cast<std::size_t>(i), Lanes{});
  }
}

/// Calls f(first, lanes) for chunks of consecutive elements of [0, n): on the GPU chunks of G,
/// lane l of a group taking element first + l (which may be n or past it: the functor checks);
/// on the CPU chunks of one (first = i, a single lane). For loops whose lanes share work, such
/// as a candidate walk common to neighbouring particles.
template <unsigned G, typename F>
struct ChunkOf {
  F f;
  KF_HD KF_INLINE void operator()(std::size_t item, Lanes g) const { f(item * g.size, g); }
};
/// Threads per CUDA block of for_each_chunk: a functor sizing per-block shared memory by it.
constexpr unsigned kChunkBlock = 128;
template <unsigned G, unsigned Block = kChunkBlock, typename F>
void for_each_chunk(const Exec& ex, std::size_t n, const F& f, const char* label) {
  const std::size_t items = ex.backend == Backend::Cuda ? (n + G - 1) / G : n;
  for_each_lanes<G, Block>(ex, items, ChunkOf<G, F>{f}, label);
}

/// Adapts a per-element functor f(i) to for_each_lanes.
template <typename F>
struct WithoutLanes {
  static constexpr unsigned kBlocksPerSm = BlocksPerSmOf<F>::value;
  F f;
  KF_HD KF_INLINE void operator()(std::size_t i, Lanes) const { f(i); }
};

/// Threads per CUDA block of for_each. 128, not 256: a block's slot on an SM frees only when its
/// last warp ends, and the pair passes' warps end far apart (rows of unequal length), so smaller
/// blocks leave fewer warp slots idle (one H200, the dam break: the step 2-4% faster at 1M and
/// 8M; 64 slower than 256; docs/PERFORMANCE.md, "P5: a piece of the split alone").
constexpr unsigned kForEachBlock = 128;

/// Calls f(i) for i in [0, n): a CUDA kernel launch or an OpenMP static loop.
template <typename F>
void for_each(const Exec& ex, std::size_t n, const F& f, const char* label) {
  for_each_lanes<1, kForEachBlock>(ex, n, WithoutLanes<F>{f}, label);
}

/// The elements a pass runs over: the first n when index is null, else index[0 .. n) (a rank's
/// owned particles its peers receive as ghosts, or the rest: the pass split around a halo
/// exchange in flight). With `only` (and no index), those of the first n whose flag is nonzero
/// (a rank's owned rows among its ghosts, whose results the exchange after the pass brings).
struct Rows {
  const std::uint32_t* index = nullptr;
  std::size_t n = 0;
  const std::uint32_t* only = nullptr;
};

/// Adapts a per-element functor f(i) to the elements of an index list.
template <typename F>
struct OnListedRows {
  static constexpr unsigned kBlocksPerSm = BlocksPerSmOf<F>::value;
  const std::uint32_t* index;
  F f;
  KF_HD KF_INLINE void operator()(std::size_t k) const { f(index[k]); }
};

/// Adapts a per-element functor f(i) to the flagged elements of a range.
template <typename F>
struct OnFlaggedRows {
  static constexpr unsigned kBlocksPerSm = BlocksPerSmOf<F>::value;
  const std::uint32_t* only;
  F f;
  KF_HD KF_INLINE void operator()(std::size_t i) const {
    if (only[i] != 0)
      f(i);
  }
};

/// Calls f(i) for the elements `rows` names, as for_each does for [0, n).
template <typename F>
void for_rows(const Exec& ex, const Rows& rows, const F& f, const char* label) {
  if (rows.index)
    for_each(ex, rows.n, OnListedRows<F>{rows.index, f}, label);
  else if (rows.only)
    for_each(ex, rows.n, OnFlaggedRows<F>{rows.only, f}, label);
  else
    for_each(ex, rows.n, f, label);
}

struct SumOp {
  template <typename T>
  KF_HD KF_INLINE T operator()(const T& a, const T& b) const {
    return a + b;
  }
};
struct MaxOp {
  template <typename T>
  KF_HD KF_INLINE T operator()(const T& a, const T& b) const {
    return a < b ? b : a;
  }
};
struct MinOp {
  template <typename T>
  KF_HD KF_INLINE T operator()(const T& a, const T& b) const {
    return b < a ? b : a;
  }
};

#if defined(__CUDACC__)
// Fixed grid so the reduction tree, and therefore a floating-point sum, is the same every call.
constexpr unsigned kReduceBlocks = 512;
constexpr unsigned kReduceThreads = 256;

// Each thread folds its grid-stride elements starting from its first one (not from init, which
// need not be op's identity); threads past n hold no value and are left out via num_valid. They
// are always the tail of the last block, which is what BlockReduce's num_valid expects.
template <typename R, typename Op, typename F>
__global__ void __launch_bounds__(kReduceThreads)
    transform_reduce_kernel(std::size_t n, R placeholder, Op op, F f, R* partial) {
  await_previous_kernel();
  using BlockReduce = cub::BlockReduce<R, kReduceThreads>;
  __shared__ typename BlockReduce::TempStorage tmp;
  const std::size_t first = static_cast<std::size_t>(blockIdx.x) * blockDim.x;
  const std::size_t stride = static_cast<std::size_t>(gridDim.x) * blockDim.x;
  std::size_t i = first + threadIdx.x;
  R acc = placeholder;
  if (i < n) {
    acc = f(i);
    for (i += stride; i < n; i += stride)
      acc = op(acc, f(i));
  }
  const int valid =
      n - first < blockDim.x ? static_cast<int>(n - first) : static_cast<int>(blockDim.x);
  R block = BlockReduce(tmp).Reduce(acc, op, valid);
  if (threadIdx.x == 0)
    partial[blockIdx.x] = block;
}

// One block folds the per-block partials, then applies the start value exactly once: init
// (*out = op(init, total)), or with Into the value already at *out (*out = op(*out, total)).
template <bool Into, typename R, typename Op>
__global__ void __launch_bounds__(kReduceThreads)
    reduce_partials_kernel(unsigned nblocks, R init, Op op, const R* partial, R* out) {
  await_previous_kernel();
  using BlockReduce = cub::BlockReduce<R, kReduceThreads>;
  __shared__ typename BlockReduce::TempStorage tmp;
  R acc = init;
  if (threadIdx.x < nblocks) {
    acc = partial[threadIdx.x];
    for (unsigned i = threadIdx.x + blockDim.x; i < nblocks; i += blockDim.x)
      acc = op(acc, partial[i]);
  }
  const int valid = nblocks < blockDim.x ? static_cast<int>(nblocks) : static_cast<int>(blockDim.x);
  R total = BlockReduce(tmp).Reduce(acc, op, valid);
  if (threadIdx.x == 0)
    *out = op(Into ? *out : init, total);
}
#endif

#if defined(__CUDACC__)
// Launches the first pass into the reduce scratch slot; returns the partials and their count.
template <typename R, typename Op, typename F>
R* launch_block_partials(std::size_t n, R placeholder, Op op, const F& f, unsigned& blocks,
                         const char* label) {
  // partial[0..kReduceBlocks) per block, partial[kReduceBlocks] the result.
  R* partial =
      static_cast<R*>(cuda_scratch(ScratchSlot::Reduce, (kReduceBlocks + 1) * sizeof(R), label));
  const std::size_t want = (n + kReduceThreads - 1) / kReduceThreads;
  blocks = static_cast<unsigned>(want < kReduceBlocks ? want : kReduceBlocks);
  launch(transform_reduce_kernel<R, Op, F>, blocks, kReduceThreads, label, n, n, placeholder, op, f,
         partial);
  KF_CHECK_LAUNCH(label, n);
  return partial;
}
#endif

template <typename R, typename Op, typename F>
R host_transform_reduce(std::size_t n, R init, Op op, const F& f) {
  // Fixed contiguous chunk per thread and an in-order combine: the same result every run (an
  // omp critical combine would add the partials in arrival order).
#if defined(_OPENMP)
  const int max_threads = omp_get_max_threads();
#else
  const int max_threads = 1;
#endif
  std::vector<R> part(static_cast<std::size_t>(max_threads), init);
  std::vector<unsigned char> has(static_cast<std::size_t>(max_threads), 0);
#pragma omp parallel num_threads(max_threads) if (n >= 4096)
  {
#if defined(_OPENMP)
    const std::size_t t = static_cast<std::size_t>(omp_get_thread_num());
    const std::size_t nt = static_cast<std::size_t>(omp_get_num_threads());
#else
    const std::size_t t = 0, nt = 1;
#endif
    const std::size_t lo = n * t / nt, hi = n * (t + 1) / nt;
    if (lo < hi) {
      R acc = f(lo);
      for (std::size_t i = lo + 1; i < hi; ++i)
        acc = op(acc, f(i));
      part[t] = acc;
      has[t] = 1;
    }
  }
  R result = init;
  for (std::size_t t = 0; t < part.size(); ++t)
    if (has[t])
      result = op(result, part[t]);
  return result;
}

/// Returns op-reduction of f(i) over [0, n) starting from init (applied once; it need not be op's
/// identity), on the host. op must be associative and commutative (SumOp, MaxOp, MinOp). The result
/// is deterministic for a given n (and, on CPU, thread count); CPU and CUDA floating-point sums
/// differ in rounding because their trees differ. On CUDA this waits for the device (the result
/// is read back); use transform_reduce_into where the host does not need the value now.
template <typename R, typename Op, typename F>
R transform_reduce(const Exec& ex, std::size_t n, R init, Op op, const F& f, const char* label) {
  if (n == 0)
    return init;
  if (ex.backend == Backend::Cuda) {
#if defined(__CUDACC__)
    unsigned blocks = 0;
    KernelTimeScope timed(label);
    R* partial = launch_block_partials(n, init, op, f, blocks, label);
    launch(reduce_partials_kernel<false, R, Op>, 1, kReduceThreads, label, blocks, blocks, init, op,
           static_cast<const R*>(partial), partial + kReduceBlocks);
    KF_CHECK_LAUNCH(label, blocks);
    R out = init;
    cuda_read_result(&out, partial + kReduceBlocks, sizeof(R), label);
    return out;
#else
    throw_not_compiled_for_cuda(label);
#endif
  }
  return host_transform_reduce(n, init, op, f);
}

/// *out = op-reduction of f(i) over [0, n) starting from init, where out points to memory on
/// ex.backend: transform_reduce without the read, so several results come back in one copy.
template <typename R, typename Op, typename F>
void transform_reduce_to(const Exec& ex, std::size_t n, R init, Op op, const F& f, R* out,
                         const char* label) {
  if (ex.backend == Backend::Cuda) {
#if defined(__CUDACC__)
    if (n == 0) {
      for_each(ex, 1, FillWith<R>{out, init}, label);
      return;
    }
    unsigned blocks = 0;
    KernelTimeScope timed(label);
    R* partial = launch_block_partials(n, init, op, f, blocks, label);
    launch(reduce_partials_kernel<false, R, Op>, 1, kReduceThreads, label, blocks, blocks, init, op,
           static_cast<const R*>(partial), out);
    KF_CHECK_LAUNCH(label, blocks);
    return;
#else
    throw_not_compiled_for_cuda(label);
#endif
  }
  *out = host_transform_reduce(n, init, op, f);
}

/// *acc = op(*acc, op-reduction of f(i) over [0, n)), where acc points to memory on ex.backend:
/// the result stays on the device, nothing waits (counters read at the diagnostics' cadence).
template <typename R, typename Op, typename F>
void transform_reduce_into(const Exec& ex, std::size_t n, Op op, const F& f, R* acc,
                           const char* label) {
  if (n == 0)
    return;
  if (ex.backend == Backend::Cuda) {
#if defined(__CUDACC__)
    unsigned blocks = 0;
    KernelTimeScope timed(label);
    R* partial = launch_block_partials(n, R{}, op, f, blocks, label);
    launch(reduce_partials_kernel<true, R, Op>, 1, kReduceThreads, label, blocks, blocks, R{}, op,
           static_cast<const R*>(partial), acc);
    KF_CHECK_LAUNCH(label, blocks);
    return;
#else
    throw_not_compiled_for_cuda(label);
#endif
  }
  *acc = host_transform_reduce(n, *acc, op, f); // init applied once: same as op(*acc, total)
}

/// *p += v atomically, on either backend (a CUDA atomic, or a relaxed host atomic inside an OpenMP
/// loop). Integer sums are exact, so their result does not depend on the order of the adds.
KF_HD KF_INLINE void atomic_add(std::uint64_t* p, std::uint64_t v) {
#if defined(__CUDA_ARCH__)
  atomicAdd(reinterpret_cast<unsigned long long*>(p), static_cast<unsigned long long>(v));
#else
  __atomic_fetch_add(p, v, __ATOMIC_RELAXED);
#endif
}

/// The same for a 32-bit count, returning the value before the add: where an item appended by
/// many threads goes (the order of the appends is not fixed; sort after if it matters).
KF_HD KF_INLINE std::uint32_t atomic_fetch_add(std::uint32_t* p, std::uint32_t v) {
#if defined(__CUDA_ARCH__)
  return atomicAdd(p, v);
#else
  return __atomic_fetch_add(p, v, __ATOMIC_RELAXED);
#endif
}

#if defined(__CUDACC__)
__device__ KF_INLINE void atomic_max_nonnegative(float* p, float v) {
  atomicMax(reinterpret_cast<unsigned*>(p), __float_as_uint(v));
}
__device__ KF_INLINE void atomic_max_nonnegative(double* p, double v) {
  atomicMax(reinterpret_cast<unsigned long long*>(p),
            static_cast<unsigned long long>(__double_as_longlong(v)));
}
#endif

/// K non-negative values, reduced element by element (max_into_each).
template <typename T, unsigned K>
struct Maxima {
  T v[K];
};
/// Where max_into_each puts its K maxima: a device word each (memory on the pass's backend).
template <typename T, unsigned K>
struct MaxTargets {
  T* word[K];
};
/// Adapts a single-value functor to max_into_each.
template <typename T, typename F>
struct OneMaximum {
  F f;
  KF_HD KF_INLINE Maxima<T, 1> operator()(std::size_t i) const { return {{f(i)}}; }
};
struct EachMaxOp {
  template <typename T, unsigned K>
  KF_HD KF_INLINE Maxima<T, K> operator()(const Maxima<T, K>& a, const Maxima<T, K>& b) const {
    Maxima<T, K> m;
    for (unsigned k = 0; k < K; ++k)
      m.v[k] = a.v[k] < b.v[k] ? b.v[k] : a.v[k];
    return m;
  }
};

#if defined(__CUDACC__)
// Grid-stride: each thread folds its elements in registers, then one block reduction of all K
// values and K atomics a block. Zero is the identity (the values are non-negative). With one
// element a thread and K reductions a block, the fluid lists' 7-value displacement reading took
// 3x its bandwidth floor (H100, the column: ~50 us for 44 MB).
template <typename T, unsigned K, typename F>
__global__ void __launch_bounds__(kReduceThreads)
    max_into_each_kernel(std::size_t n, F f, MaxTargets<T, K> acc) {
  await_previous_kernel();
  using BlockReduce = cub::BlockReduce<Maxima<T, K>, kReduceThreads>;
  __shared__ typename BlockReduce::TempStorage tmp;
  const std::size_t stride = static_cast<std::size_t>(gridDim.x) * blockDim.x;
  Maxima<T, K> m{};
  for (std::size_t i = static_cast<std::size_t>(blockIdx.x) * blockDim.x + threadIdx.x; i < n;
       i += stride)
    m = EachMaxOp{}(m, f(i));
  const Maxima<T, K> block = BlockReduce(tmp).Reduce(m, EachMaxOp{});
  if (threadIdx.x == 0)
    for (unsigned k = 0; k < K; ++k)
      atomic_max_nonnegative(acc.word[k], block.v[k]);
}
#endif

/// max_into for K values at once: *acc.word[k] = max(*acc.word[k], f(i).v[k] over [0, n)), f
/// returning Maxima<T, K> of non-negative values (NaN mapped to a large value by f). One pass.
template <typename T, unsigned K, typename F>
void max_into_each(const Exec& ex, std::size_t n, const F& f, MaxTargets<T, K> acc,
                   const char* label) {
  static_assert(std::is_floating_point_v<T>, "max_into_each: float or double values");
  if (n == 0)
    return;
  if (ex.backend == Backend::Cuda) {
#if defined(__CUDACC__)
    // Enough blocks to fill the GPU (the grid strides over the rest).
    const std::size_t want = (n + kReduceThreads - 1) / kReduceThreads;
    const std::size_t grid = want < 2 * kReduceBlocks ? want : 2 * kReduceBlocks;
    KernelTimeScope timed(label);
    launch(max_into_each_kernel<T, K, F>, grid, kReduceThreads, label, n, n, f, acc);
    KF_CHECK_LAUNCH(label, n);
    return;
#else
    throw_not_compiled_for_cuda(label);
#endif
  }
  Maxima<T, K> init;
  for (unsigned k = 0; k < K; ++k)
    init.v[k] = *acc.word[k];
  const Maxima<T, K> m = host_transform_reduce(n, init, EachMaxOp{}, f);
  for (unsigned k = 0; k < K; ++k)
    *acc.word[k] = m.v[k];
}

/// max_into_each into K consecutive words acc[0, K).
template <typename T, unsigned K, typename F>
void max_into_each(const Exec& ex, std::size_t n, const F& f, T* acc, const char* label) {
  MaxTargets<T, K> words;
  for (unsigned k = 0; k < K; ++k)
    words.word[k] = acc + k;
  max_into_each<T, K>(ex, n, f, words, label);
}

/// *acc = max(*acc, f(i) over [0, n)) for values f(i) >= 0 (+0, never -0; f maps a NaN to a
/// large value itself), where acc points to memory on ex.backend. One pass, f called once per i
/// (it may write outputs too): the blocks meet in an atomic max on the values' bits, which order
/// like the values when non-negative; a max is exact, so the result does not depend on the
/// order. Nothing waits.
template <typename T, typename F>
void max_into(const Exec& ex, std::size_t n, const F& f, T* acc, const char* label) {
  max_into_each<T, 1>(ex, n, OneMaximum<T, F>{f}, acc, label);
}

/// Stable ascending sort of keys (only the low `key_bits` bits are looked at), carrying values.
/// Both buffers must be on ex.backend and hold n elements; the sort is done in place.
void sort_by_key(const Exec& ex, DeviceBuffer<std::uint32_t>& keys,
                 DeviceBuffer<std::uint32_t>& values, int key_bits, const char* label);
/// The same on n keys and values at raw pointers on ex.backend (memory the caller holds: a GL
/// buffer mapped into CUDA, a host vector).
void sort_by_key(const Exec& ex, std::uint32_t* keys, std::uint32_t* values, std::size_t n,
                 int key_bits, const char* label);

/// out[i] = sum of in[0..i); returns the total. out may alias in.
std::uint64_t exclusive_scan(const Exec& ex, const DeviceBuffer<std::uint32_t>& in,
                             DeviceBuffer<std::uint32_t>& out, const char* label);

/// Stream compaction: out becomes the indices i with flags[i] != 0, in increasing order, and
/// their count is returned. offsets is scratch (resized to flags.size()).
std::size_t flagged_indices(const Exec& ex, const DeviceBuffer<std::uint32_t>& flags,
                            DeviceBuffer<std::uint32_t>& offsets, DeviceBuffer<std::uint32_t>& out,
                            const char* label);

// Named functors, not device lambdas, in these shared inline templates: nvcc's host-device lambda
// wrappers instantiated from several translation units have called a null function on the CPU
// backend of the CUDA build (a skin check did; docs/ARCHITECTURE.md).
template <typename T>
struct GatherBy {
  const std::uint32_t* perm;
  const T* src;
  T* dst;
  KF_HD KF_INLINE void operator()(std::size_t i) const { dst[i] = src[perm[i]]; }
};

/// Fills buf[0..n) with value.
template <typename T>
void fill(const Exec& ex, DeviceBuffer<T>& buf, T value, const char* label) {
  for_each(ex, buf.size(), FillWith<T>{buf.data(), value}, label);
}

/// dst[i] = src[perm[i]] — reorders one per-particle field after a sort.
template <typename T>
void gather(const Exec& ex, const DeviceBuffer<std::uint32_t>& perm, const DeviceBuffer<T>& src,
            DeviceBuffer<T>& dst, const char* label) {
  if (dst.size() != perm.size())
    throw Error(std::string(label) + ": gather into " + std::to_string(dst.size()) +
                " elements with a permutation of " + std::to_string(perm.size()));
  for_each(ex, perm.size(), GatherBy<T>{perm.data(), src.data(), dst.data()}, label);
}

} // namespace kf::exec
