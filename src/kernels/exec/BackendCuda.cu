// Device side of the execution layer: CUDA memory, copies, device selection, and the CUB radix
// sort and scan. Declared in BackendCpu.cpp, which dispatches here for Backend::Cuda. Everything
// runs on the legacy default stream, so it is ordered with the kernels Algorithms.hpp launches
// (a pass in an OnSideStream scope excepted: Streams.hpp).
#include "core/Error.hpp"
#include "kernels/exec/Algorithms.hpp"
#include "kernels/exec/CudaCheck.hpp"
#include "kernels/exec/DeviceBuffer.hpp"
#include "kernels/exec/Streams.hpp"

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <string>
#include <string_view>

#include <cub/device/device_radix_sort.cuh>
#include <cub/device/device_reduce.cuh>
#include <cub/device/device_scan.cuh>
#include <cuda/std/functional>
#include <cuda_runtime.h>

namespace kf::exec {

namespace {

std::string mib(std::size_t bytes) {
  return std::to_string((bytes + (1u << 19)) >> 20) + " MiB";
}

std::string error_text(cudaError_t e) {
  return std::string(cudaGetErrorName(e)) + ": " + cudaGetErrorString(e);
}

// Keeps only the file name: full build paths make one-line messages unreadable.
const char* base_name(const char* file) {
  const char* slash = std::strrchr(file, '/');
  return slash ? slash + 1 : file;
}

int current_device() {
  int d = 0;
  KF_CUDA(cudaGetDevice(&d), std::string("querying the current CUDA device"));
  return d;
}

// CUB sizes are 32-bit here: 32-bit offsets are CUB's fast path, and the values are uint32
// indices anyway, so more than 2^32-1 elements cannot be meaningful.
std::uint32_t checked_count(std::size_t n, const char* op, const char* label) {
  if (n > std::numeric_limits<std::uint32_t>::max())
    throw Error(std::string(label) + ": " + op + " of " + std::to_string(n) +
                " elements exceeds the CUDA backend's limit of 2^32-1");
  return static_cast<std::uint32_t>(n);
}

// Rounds a byte offset up so that every sub-array carved out of one scratch block stays aligned
// the way cudaMalloc aligns (256 bytes), which CUB's vectorised loads want.
constexpr std::size_t align_up(std::size_t bytes) {
  return (bytes + 255) / 256 * 256;
}

// Widens the scanned values so the total cannot wrap at 2^32.
struct Widen {
  __host__ __device__ std::uint64_t operator()(std::uint32_t v) const { return v; }
};

} // namespace

// ---- errors -------------------------------------------------------------------------------------

void throw_cuda_error(cudaError_t e, const char* what, const char* file, int line) {
  // Clears a non-sticky error so that the next launch check does not report it a second time.
  (void)cudaGetLastError();
  throw Error("CUDA error in " + std::string(what) + " (" + base_name(file) + ":" +
              std::to_string(line) + "): " + error_text(e));
}

void throw_cuda_error(cudaError_t e, const char* what, const char* file, int line,
                      const std::string& context) {
  (void)cudaGetLastError();
  throw Error(context + ": " + error_text(e) + " (in " + what + ", " + base_name(file) + ":" +
              std::to_string(line) + ")");
}

bool launch_overlap() {
  // Compute capability 9.0 and later; KF_PDL=0 in the environment turns it off (to measure it).
  static const bool on = [] {
    const char* v = std::getenv("KF_PDL");
    if (v && v[0] == '0')
      return false;
    int device = 0, major = 0;
    return cudaGetDevice(&device) == cudaSuccess &&
           cudaDeviceGetAttribute(&major, cudaDevAttrComputeCapabilityMajor, device) ==
               cudaSuccess &&
           major >= 9;
  }();
  return on;
}

void throw_launch_error(cudaError_t e, const char* label, std::size_t n) {
  throw_cuda_error(e, "cudaLaunchKernelEx", __FILE__, __LINE__,
                   std::string(label) + " over " + std::to_string(n) + " elements");
}

void check_launch_impl(const char* label, std::size_t n, const char* file, int line) {
  // KF_CUDA_SYNC_CHECK=1: synchronise after every launch so that an asynchronous fault is
  // pinned on the kernel that caused it (slow; for debugging only). Read once per process.
  static const bool sync_check = [] {
    const char* v = std::getenv("KF_CUDA_SYNC_CHECK");
    return v != nullptr && std::string_view(v) == "1";
  }();
  const auto where = [&] {
    return std::string(" (") + base_name(file) + ":" + std::to_string(line) + ")";
  };
  cudaError_t e = cudaGetLastError();
  if (e != cudaSuccess)
    throw Error("kernel '" + std::string(label) + "' (n=" + std::to_string(n) +
                ") failed to launch: " + error_text(e) + where());
  if (sync_check) {
    e = cudaDeviceSynchronize();
    if (e != cudaSuccess) {
      (void)cudaGetLastError();
      throw Error("kernel '" + std::string(label) + "' (n=" + std::to_string(n) +
                  ") failed while running: " + error_text(e) + where() + " [KF_CUDA_SYNC_CHECK=1]");
    }
  }
}

// ---- kernel times (KF_KERNEL_TIMES=1) -----------------------------------------------------------

namespace {

struct KernelTimes {
  struct Pending {
    const char* label;
    cudaEvent_t start, end;
  };
  struct Total {
    std::string label;
    std::uint64_t launches = 0;
    double ms = 0;
  };
  std::vector<cudaEvent_t> free_events;
  std::vector<Pending> pending;
  std::vector<Total> totals;
  std::vector<Total> waits; // the host blocked on the device: reads of results, by label
  cudaEvent_t first = nullptr, last = nullptr; // the span: first start, latest end
  double busy_ms = 0;
  int depth = 0; // nested scopes (a reduction inside a timed stage) are counted once, outermost

  cudaEvent_t event() {
    if (free_events.empty()) {
      cudaEvent_t e;
      KF_CUDA(cudaEventCreate(&e), std::string("creating a kernel-time event"));
      return e;
    }
    cudaEvent_t e = free_events.back();
    free_events.pop_back();
    return e;
  }
  // Waits for the pending events and adds their times; keeps the span's end event.
  void resolve() {
    if (pending.empty())
      return;
    for (const Pending& p : pending) {
      // Each end: a side stream's (Streams.hpp) may finish after the last one recorded.
      KF_CUDA(cudaEventSynchronize(p.end), std::string("kernel times"));
      float ms = 0;
      KF_CUDA(cudaEventElapsedTime(&ms, p.start, p.end), std::string("kernel times"));
      add(totals, p.label, ms);
      busy_ms += ms;
      if (p.start != first)
        free_events.push_back(p.start);
      if (p.end != last)
        free_events.push_back(p.end);
    }
    pending.clear();
  }
  void note_wait(const char* label, double ms) { add(waits, label, ms); }
  // One more launch (or wait) of `label` taking ms, into its entry of `list`.
  static void add(std::vector<Total>& list, const char* label, double ms) {
    auto it =
        std::find_if(list.begin(), list.end(), [&](const Total& t) { return t.label == label; });
    if (it == list.end()) {
      list.push_back({label});
      it = list.end() - 1;
    }
    ++it->launches;
    it->ms += ms;
  }
  void report() {
    resolve();
    if (totals.empty() || !first || !last)
      return;
    float span = 0;
    KF_CUDA(cudaEventElapsedTime(&span, first, last), std::string("kernel times"));
    std::sort(totals.begin(), totals.end(),
              [](const Total& a, const Total& b) { return a.ms > b.ms; });
    std::fprintf(stderr,
                 "kernel times (KF_KERNEL_TIMES=1): GPU busy %.1f of %.1f ms timed (%.0f%%)\n"
                 "  %-34s %10s %10s %9s %6s\n",
                 busy_ms, double(span), span > 0 ? 100.0 * busy_ms / span : 0.0, "label",
                 "launches", "total ms", "mean us", "share");
    for (const Total& t : totals)
      std::fprintf(stderr, "  %-34s %10llu %10.2f %9.2f %5.1f%%\n", t.label.c_str(),
                   static_cast<unsigned long long>(t.launches), t.ms, 1e3 * t.ms / t.launches,
                   busy_ms > 0 ? 100.0 * t.ms / busy_ms : 0.0);
    // Each wait drains the queue: the kernels after it start only once the host has launched
    // them, so waits per step bound how well launches overlap the GPU's work.
    std::sort(waits.begin(), waits.end(),
              [](const Total& a, const Total& b) { return a.launches > b.launches; });
    std::fprintf(stderr, "host waits on the device (reads of results):\n  %-34s %10s %10s\n",
                 "label", "waits", "host ms");
    for (const Total& t : waits)
      std::fprintf(stderr, "  %-34s %10llu %10.2f\n", t.label.c_str(),
                   static_cast<unsigned long long>(t.launches), t.ms);
  }
};

KernelTimes* kernel_times() {
  static KernelTimes* const times = [] {
    const char* v = std::getenv("KF_KERNEL_TIMES");
    if (v == nullptr || std::string_view(v) != "1")
      return static_cast<KernelTimes*>(nullptr);
    auto* t = new KernelTimes; // lives to the end; reported from atexit
    std::atexit([] {
      try {
        kernel_times()->report();
      } catch (const std::exception& e) {
        std::fprintf(stderr, "kernel times: %s\n", e.what());
      }
    });
    return t;
  }();
  return times;
}

// Times a host wait for the report when KF_KERNEL_TIMES=1; nothing otherwise.
class HostWaitScope {
public:
  explicit HostWaitScope(const char* label) : label_(label) {
    if (kernel_times())
      t0_ = std::chrono::steady_clock::now();
  }
  ~HostWaitScope() {
    if (KernelTimes* t = kernel_times())
      t->note_wait(label_,
                   std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0_)
                       .count());
  }
  HostWaitScope(const HostWaitScope&) = delete;
  HostWaitScope& operator=(const HostWaitScope&) = delete;

private:
  const char* label_;
  std::chrono::steady_clock::time_point t0_{};
};

} // namespace

KernelTimeScope::KernelTimeScope(const char* label) {
  KernelTimes* t = kernel_times();
  if (!t || t->depth++ > 0)
    return;
  cudaEvent_t start = t->event();
  KF_CUDA(cudaEventRecord(start, launch_stream()), std::string("kernel times"));
  if (!t->first)
    t->first = start;
  t->pending.push_back({label, start, nullptr});
  slot_ = static_cast<int>(t->pending.size()) - 1;
}

KernelTimeScope::~KernelTimeScope() {
  KernelTimes* t = kernel_times();
  if (!t)
    return;
  --t->depth;
  if (slot_ < 0)
    return;
  cudaEvent_t end = t->event();
  if (cudaEventRecord(end, launch_stream()) != cudaSuccess) {
    // A destructor does not throw; the launch's own check reports the failure. The entry (the
    // last one: timed scopes do not nest) is dropped, so resolve() never sees a missing end.
    t->free_events.push_back(end);
    t->pending.pop_back();
    return;
  }
  t->last = end; // an earlier end still pending is freed when resolved
  t->pending[static_cast<std::size_t>(slot_)].end = end;
  if (t->pending.size() >= 4096)
    t->resolve();
}

// ---- devices ------------------------------------------------------------------------------------

bool cuda_device_present() {
  // No driver or no GPU makes cudaGetDeviceCount fail: that means "no device", not an error.
  static const bool present = [] {
    int count = 0;
    const cudaError_t e = cudaGetDeviceCount(&count);
    if (e != cudaSuccess) {
      (void)cudaGetLastError();
      return false;
    }
    return count > 0;
  }();
  return present;
}

int cuda_set_device(int local_rank) {
  int count = 0;
  KF_CUDA(cudaGetDeviceCount(&count), "selecting a CUDA device (no usable CUDA device)");
  if (count <= 0 || local_rank < 0) {
    const char* vis = std::getenv("CUDA_VISIBLE_DEVICES");
    throw Error("no CUDA device for local rank " + std::to_string(local_rank) + ": " +
                std::to_string(count) + " visible (CUDA_VISIBLE_DEVICES=" + (vis ? vis : "unset") +
                ")");
  }
  const int device = local_rank % count;
  KF_CUDA(cudaSetDevice(device), "selecting CUDA device " + std::to_string(device));
  return device;
}

int cuda_device_count() {
  int count = 0;
  if (cudaGetDeviceCount(&count) != cudaSuccess) {
    (void)cudaGetLastError();
    return 0;
  }
  return count;
}

std::size_t cuda_free_memory() {
  std::size_t free_b = 0, total_b = 0;
  if (cudaMemGetInfo(&free_b, &total_b) != cudaSuccess) {
    (void)cudaGetLastError();
    return 0;
  }
  return free_b;
}

std::string cuda_describe() {
  if (!cuda_device_present())
    throw Error("describe: no CUDA device is visible");
  const int d = current_device();
  cudaDeviceProp p{};
  KF_CUDA(cudaGetDeviceProperties(&p, d), "reading properties of CUDA device " + std::to_string(d));
  return std::string(p.name) + ", " + std::to_string(p.multiProcessorCount) + " SMs, " +
         mib(p.totalGlobalMem) + ", sm_" + std::to_string(p.major) + std::to_string(p.minor) +
         ", device " + std::to_string(d);
}

void cuda_synchronize() {
  // Faults of earlier kernels surface here; KF_CUDA_SYNC_CHECK=1 pins them to the kernel.
  KF_CUDA(cudaDeviceSynchronize(),
          std::string("waiting for queued GPU work (a kernel launched earlier failed; run with "
                      "KF_CUDA_SYNC_CHECK=1 to name it)"));
}

// ---- memory -------------------------------------------------------------------------------------

void* cuda_alloc(std::size_t bytes, const char* what) {
  void* p = nullptr;
  const cudaError_t e = cudaMalloc(&p, bytes);
  if (e == cudaErrorMemoryAllocation) {
    (void)cudaGetLastError(); // out-of-memory is not sticky; the context stays usable
    std::size_t free_b = 0, total_b = 0;
    const bool info = cudaMemGetInfo(&free_b, &total_b) == cudaSuccess;
    (void)cudaGetLastError();
    throw Error(
        "out of GPU memory: requested " + std::to_string(bytes) + " bytes (" + mib(bytes) +
        ") for '" + what + "'; " +
        (info ? mib(free_b) + " free of " + mib(total_b) : std::string("free memory unknown")) +
        " on device " + std::to_string(current_device()));
  }
  if (e != cudaSuccess)
    throw_cuda_error(e, "cudaMalloc", __FILE__, __LINE__,
                     "allocating " + std::to_string(bytes) + " bytes of GPU memory for '" + what +
                         "'");
  return p;
}

void cuda_free(void* p) noexcept {
  // Cannot throw (destructors call this). A failure here is either process teardown or a sticky
  // error that the next checked call reports; clear a non-sticky one so it is not misattributed to
  // the next kernel launch.
  if (cudaFree(p) != cudaSuccess)
    (void)cudaGetLastError();
}

void cuda_copy(void* dst, bool dst_dev, const void* src, bool src_dev, std::size_t bytes) {
  const cudaMemcpyKind kind = dst_dev
                                  ? (src_dev ? cudaMemcpyDeviceToDevice : cudaMemcpyHostToDevice)
                                  : (src_dev ? cudaMemcpyDeviceToHost : cudaMemcpyHostToHost);
  KF_CUDA(cudaMemcpy(dst, src, bytes, kind), "copying " + std::to_string(bytes) + " bytes " +
                                                 (src_dev ? "device" : "host") + "->" +
                                                 (dst_dev ? "device" : "host"));
}

void cuda_fill(void* p, unsigned char byte, std::size_t bytes) {
  // Synchronised: a stream that does not wait on the legacy default one may use p next.
  KF_CUDA(cudaMemset(p, byte, bytes), "setting " + std::to_string(bytes) + " bytes");
  KF_CUDA(cudaDeviceSynchronize(), "setting " + std::to_string(bytes) + " bytes");
}

void* cuda_alloc_pinned(std::size_t bytes, const char* what) {
  void* p = nullptr;
  KF_CUDA(cudaMallocHost(&p, bytes), std::string("allocating ") + std::to_string(bytes) +
                                         " bytes of page-locked host memory for '" + what + "'");
  return p;
}

void cuda_free_pinned(void* p) noexcept {
  if (p && cudaFreeHost(p) != cudaSuccess)
    (void)cudaGetLastError();
}

void* cuda_event_create(const char* what) {
  cudaEvent_t e = nullptr;
  KF_CUDA(cudaEventCreateWithFlags(&e, cudaEventDisableTiming),
          std::string("creating an event for '") + what + "'");
  return e;
}

void cuda_event_destroy(void* e) noexcept {
  if (e && cudaEventDestroy(static_cast<cudaEvent_t>(e)) != cudaSuccess)
    (void)cudaGetLastError();
}

void* cuda_timing_event_create(const char* what) {
  cudaEvent_t e = nullptr;
  KF_CUDA(cudaEventCreate(&e), std::string("creating a timing event for '") + what + "'");
  return e;
}

void cuda_event_record(void* e, const char* label) {
  KF_CUDA(cudaEventRecord(static_cast<cudaEvent_t>(e), launch_stream()),
          std::string(label) + ": recording an event");
}

// ---- the side stream (Streams.hpp) --------------------------------------------------------------

CUstream_st* cuda_side_stream_create() {
  cudaStream_t s = nullptr;
  // Non-blocking: the legacy default stream's implicit waits would serialise the two again.
  KF_CUDA(cudaStreamCreateWithFlags(&s, cudaStreamNonBlocking), std::string("creating a stream"));
  return s;
}

void cuda_stream_destroy(CUstream_st* s) noexcept {
  if (s && cudaStreamDestroy(s) != cudaSuccess)
    (void)cudaGetLastError();
}

void* cuda_order_event_create(const char* what) {
  cudaEvent_t e = nullptr;
  KF_CUDA(cudaEventCreateWithFlags(&e, cudaEventDisableTiming),
          std::string("creating an event for ") + what);
  return e;
}

void cuda_stream_after(CUstream_st* waiter, CUstream_st* done, void* event, const char* label) {
  const auto e = static_cast<cudaEvent_t>(event);
  KF_CUDA(cudaEventRecord(e, done ? done : cudaStreamLegacy), std::string(label));
  KF_CUDA(cudaStreamWaitEvent(waiter ? waiter : cudaStreamLegacy, e, 0), std::string(label));
}

double cuda_event_seconds(void* start, void* end, const char* label) {
  float ms = 0;
  KF_CUDA(cudaEventElapsedTime(&ms, static_cast<cudaEvent_t>(start), static_cast<cudaEvent_t>(end)),
          std::string(label) + ": reading the time between two events");
  return 1e-3 * double(ms);
}

void cuda_copy_to_host_async(void* dst, const void* src, std::size_t bytes, void* event,
                             const char* label) {
  if (bytes)
    KF_CUDA(cudaMemcpyAsync(dst, src, bytes, cudaMemcpyDeviceToHost, 0),
            std::string(label) + ": queueing a " + std::to_string(bytes) + "-byte read");
  KF_CUDA(cudaEventRecord(static_cast<cudaEvent_t>(event), 0),
          std::string(label) + ": marking a read");
}

void cuda_event_wait(void* e, const char* label) {
  HostWaitScope waited(label);
  KF_CUDA(cudaEventSynchronize(static_cast<cudaEvent_t>(e)),
          std::string(label) +
              ": waiting for a read from the device (a kernel queued earlier may have failed; "
              "run with KF_CUDA_SYNC_CHECK=1 to name it)");
}

// ---- scratch ------------------------------------------------------------------------------------

namespace {

struct Scratch {
  void* ptr = nullptr;
  std::size_t bytes = 0;
};
// One process drives one device (rank -> device), so one set of slots suffices. Freed at exit
// by the runtime's teardown; never freed earlier, so pointers handed out stay valid.
Scratch g_scratch[static_cast<int>(ScratchSlot::Count)];
void* g_pinned = nullptr;
constexpr std::size_t kPinnedBytes = 4096;

// Page-locked host memory that small device results are copied into before the host reads them.
void* pinned_staging(std::size_t bytes, const char* label) {
  if (bytes > kPinnedBytes)
    throw Error(std::string(label) + ": a device result of " + std::to_string(bytes) +
                " bytes exceeds the pinned staging buffer (" + std::to_string(kPinnedBytes) +
                " bytes)");
  if (!g_pinned)
    g_pinned = cuda_alloc_pinned(kPinnedBytes, label);
  return g_pinned;
}

} // namespace

void* cuda_scratch(ScratchSlot slot, std::size_t bytes, const char* label) {
  Scratch& s = g_scratch[static_cast<int>(slot)];
  // A slot's users are ordered by the legacy default stream alone.
  if (launch_stream() != nullptr)
    throw Error(std::string("internal: '") + label + "' uses a scratch slot on a side stream");
  if (bytes <= s.bytes)
    return s.ptr;
  // Grow by half again so a slowly growing particle count does not reallocate every step.
  const std::size_t want = std::max(bytes, s.bytes + s.bytes / 2);
  cuda_free(s.ptr); // cudaFree waits for queued work that may still use the old block
  s.ptr = nullptr;
  s.bytes = 0;
  const std::string what = std::string(label) + " (scratch)";
  s.ptr = cuda_alloc(want, what.c_str());
  s.bytes = want;
  return s.ptr;
}

void cuda_read_result(void* dst, const void* device_src, std::size_t bytes, const char* label) {
  void* staging = pinned_staging(bytes, label);
  const auto ctx = [&] {
    return std::string(label) + ": reading a " + std::to_string(bytes) +
           "-byte result from the device (a kernel queued earlier may have failed; run with "
           "KF_CUDA_SYNC_CHECK=1 to name it)";
  };
  KF_CUDA(cudaMemcpyAsync(staging, device_src, bytes, cudaMemcpyDeviceToHost, 0), ctx());
  HostWaitScope waited(label);
  KF_CUDA(cudaStreamSynchronize(0), ctx());
  std::memcpy(dst, staging, bytes);
}

// ---- sort and scan ------------------------------------------------------------------------------

void cuda_sort_by_key(std::uint32_t* keys, std::uint32_t* values, std::size_t count, int key_bits,
                      const char* label) {
  if (key_bits < 0 || key_bits > 32)
    throw Error(std::string(label) + ": sort_by_key with key_bits=" + std::to_string(key_bits) +
                " (expected 0..32)");
  const std::uint32_t n = checked_count(count, "sort_by_key", label);
  if (n < 2 || key_bits == 0)
    return; // already sorted
  KernelTimeScope timed(label);
  const auto ctx = [&] {
    return std::string(label) + ": sort_by_key of " + std::to_string(n) + " pairs, " +
           std::to_string(key_bits) + " key bits";
  };

  // One scratch block: alternate keys, alternate values, then CUB's temporary storage. Sizing
  // needs only the element count; the pointers may be null.
  const std::size_t array_bytes = align_up(std::size_t(n) * sizeof(std::uint32_t));
  cub::DoubleBuffer<std::uint32_t> dk(keys, nullptr), dv(values, nullptr);
  std::size_t temp_bytes = 0;
  KF_CUDA(cub::DeviceRadixSort::SortPairs(nullptr, temp_bytes, dk, dv, n, 0, key_bits), ctx());
  auto* scratch = static_cast<unsigned char*>(
      cuda_scratch(ScratchSlot::Sort, 2 * array_bytes + temp_bytes, label));
  auto* alt_keys = reinterpret_cast<std::uint32_t*>(scratch);
  auto* alt_values = reinterpret_cast<std::uint32_t*>(scratch + array_bytes);
  dk = cub::DoubleBuffer<std::uint32_t>(keys, alt_keys);
  dv = cub::DoubleBuffer<std::uint32_t>(values, alt_values);
  KF_CUDA(cub::DeviceRadixSort::SortPairs(scratch + 2 * array_bytes, temp_bytes, dk, dv, n, 0,
                                          key_bits),
          ctx());

  // The pass count decides which half holds the result; bring it home if it ended in scratch.
  const std::size_t bytes = std::size_t(n) * sizeof(std::uint32_t);
  if (dk.Current() != keys)
    KF_CUDA(cudaMemcpyAsync(keys, dk.Current(), bytes, cudaMemcpyDeviceToDevice),
            ctx() + " (copying keys back)");
  if (dv.Current() != values)
    KF_CUDA(cudaMemcpyAsync(values, dv.Current(), bytes, cudaMemcpyDeviceToDevice),
            ctx() + " (copying values back)");
}

void cuda_exclusive_sum(const std::uint32_t* in, std::uint32_t* out, std::size_t count,
                        const char* label) {
  if (count == 0)
    return;
  const std::uint32_t n = checked_count(count, "exclusive_scan_on_device", label);
  KernelTimeScope timed(label);
  const auto ctx = [&] {
    return std::string(label) + ": exclusive_scan_on_device of " + std::to_string(n) + " elements";
  };
  std::size_t bytes = 0;
  KF_CUDA(cub::DeviceScan::ExclusiveSum(nullptr, bytes, in, out, n), ctx());
  void* temp = cuda_scratch(ScratchSlot::Scan, bytes, label);
  KF_CUDA(cub::DeviceScan::ExclusiveSum(temp, bytes, in, out, n), ctx());
}

std::uint64_t cuda_exclusive_scan(const DeviceBuffer<std::uint32_t>& in,
                                  DeviceBuffer<std::uint32_t>& out, const char* label) {
  const std::uint32_t n = checked_count(in.size(), "exclusive_scan", label);
  if (n == 0)
    return 0;
  KernelTimeScope timed(label);
  const auto ctx = [&] {
    return std::string(label) + ": exclusive_scan of " + std::to_string(n) + " elements";
  };

  // The total is a separate 64-bit reduction, run before the scan because out may alias in (CUB
  // scans in place when the pointers are equal), and because out[n-1] + in[n-1] wraps at 2^32.
  const std::uint32_t* d_in = in.data();
  std::uint32_t* d_out = out.data();
  std::uint64_t* d_total = nullptr;
  std::size_t reduce_bytes = 0, scan_bytes = 0;
  KF_CUDA(cub::DeviceReduce::TransformReduce(nullptr, reduce_bytes, d_in, d_total, n,
                                             ::cuda::std::plus<>{}, Widen{}, std::uint64_t{0}),
          ctx());
  KF_CUDA(cub::DeviceScan::ExclusiveSum(nullptr, scan_bytes, d_in, d_out, n), ctx());
  std::size_t temp_bytes = reduce_bytes > scan_bytes ? reduce_bytes : scan_bytes;

  // One scratch block: the total (padded to keep alignment), then the shared temporary storage.
  auto* scratch = static_cast<unsigned char*>(
      cuda_scratch(ScratchSlot::Scan, align_up(sizeof(std::uint64_t)) + temp_bytes, label));
  d_total = reinterpret_cast<std::uint64_t*>(scratch);
  void* d_temp = scratch + align_up(sizeof(std::uint64_t));
  std::size_t bytes = temp_bytes;
  KF_CUDA(cub::DeviceReduce::TransformReduce(d_temp, bytes, d_in, d_total, n, ::cuda::std::plus<>{},
                                             Widen{}, std::uint64_t{0}),
          ctx() + " (total)");
  bytes = temp_bytes;
  KF_CUDA(cub::DeviceScan::ExclusiveSum(d_temp, bytes, d_in, d_out, n), ctx());

  std::uint64_t total = 0;
  cuda_read_result(&total, d_total, sizeof(total), label);
  return total;
}

} // namespace kf::exec
