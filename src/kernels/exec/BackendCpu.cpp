// Host side of the execution layer: CPU memory, the CPU sort and scan, and the dispatch to the
// CUDA implementations (BackendCuda.cu) when they are compiled in.
#include "core/Error.hpp"
#include "kernels/exec/Algorithms.hpp"
#include "kernels/exec/Backend.hpp"
#include "kernels/exec/PeakByLabel.hpp"
#include "kernels/exec/ScanOnDevice.hpp"

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <mutex>
#include <new>
#include <set>
#include <unordered_map>
#include <vector>
// Under Valgrind's memcheck a host copy out of memory never written is reported where it is
// made (scripts/test-valgrind.sh), as compute-sanitizer's initcheck reports a device copy: a
// growth copying a column's unwritten slots. Outside Valgrind a few instructions that do nothing.
#if __has_include(<valgrind/memcheck.h>)
#include <valgrind/memcheck.h>
#define KF_EXPECT_WRITTEN(p, n) (void)VALGRIND_CHECK_MEM_IS_DEFINED(p, n)
#else
#define KF_EXPECT_WRITTEN(p, n) ((void)0)
#endif

#if defined(_OPENMP)
#include <omp.h>
#endif

namespace kf::exec {

#if defined(KF_WITH_CUDA)
// Defined in BackendCuda.cu.
void* cuda_alloc(std::size_t bytes, const char* what);
void cuda_free(void* p) noexcept;
void cuda_copy(void* dst, bool dst_dev, const void* src, bool src_dev, std::size_t bytes);
void cuda_fill(void* p, unsigned char byte, std::size_t bytes);
void cuda_synchronize();
void* cuda_alloc_pinned(std::size_t bytes, const char* what);
void cuda_free_pinned(void* p) noexcept;
void* cuda_event_create(const char* what);
void cuda_event_destroy(void* e) noexcept;
void cuda_copy_to_host_async(void* dst, const void* src, std::size_t bytes, void* event,
                             const char* label);
void cuda_event_wait(void* e, const char* label);
bool cuda_device_present();
int cuda_set_device(int local_rank);
std::string cuda_describe();
std::size_t cuda_free_memory();
int cuda_device_count();
void cuda_sort_by_key(std::uint32_t* keys, std::uint32_t* values, std::size_t n, int key_bits,
                      const char* label);
std::uint64_t cuda_exclusive_scan(const DeviceBuffer<std::uint32_t>& in,
                                  DeviceBuffer<std::uint32_t>& out, const char* label);
void cuda_exclusive_sum(const std::uint32_t* in, std::uint32_t* out, std::size_t n,
                        const char* label);
#endif

#if !defined(KF_WITH_CUDA)
[[noreturn]] static void no_cuda(const char* what) {
  throw Error(std::string(what) + ": this knitflow was built without CUDA (use the 'cuda' preset)");
}
#endif

void throw_not_compiled_for_cuda(const char* label) {
  throw Error(std::string(label) +
              ": kernel launched on the CUDA backend from a file not compiled by nvcc (build bug)");
}

bool cuda_compiled() {
#if defined(KF_WITH_CUDA)
  return true;
#else
  return false;
#endif
}

bool cuda_available() {
#if defined(KF_WITH_CUDA)
  return cuda_device_present();
#else
  return false;
#endif
}

int cuda_devices() {
#if defined(KF_WITH_CUDA)
  return cuda_device_present() ? cuda_device_count() : 0;
#else
  return 0;
#endif
}

std::size_t cuda_free_memory_now() {
#if defined(KF_WITH_CUDA)
  return cuda_device_present() ? cuda_free_memory() : 0;
#else
  return 0;
#endif
}

int cuda_select_device([[maybe_unused]] int local_rank) {
#if defined(KF_WITH_CUDA)
  return cuda_set_device(local_rank);
#else
  return -1;
#endif
}

std::string describe(Backend b) {
  if (b == Backend::Cuda) {
#if defined(KF_WITH_CUDA)
    return cuda_describe();
#else
    no_cuda("describe");
#endif
  }
#if defined(_OPENMP)
  return "CPU, " + std::to_string(omp_get_max_threads()) + " OpenMP threads";
#else
  return "CPU, 1 thread (no OpenMP)";
#endif
}

namespace {

/// What alloc_bytes holds on each backend (held_bytes), and by label (peak_by_label): buffers
/// grow rarely (capacities are kept), so a lock and a small copy at a new peak cost nothing
/// measurable.
struct Ledger {
  struct Entry {
    std::size_t bytes = 0;
    std::size_t label = 0; // index into labels
  };
  std::mutex lock;
  std::unordered_map<void*, Entry> size;
  HeldBytes held[2];
  std::unordered_map<std::string, std::size_t> label_index;
  std::vector<std::string> labels;
  std::vector<std::size_t> label_now[2], label_at_peak[2]; // bytes by label index
  static Ledger& get() {
    static Ledger l;
    return l;
  }
  std::size_t intern(const char* what) {
    const std::string name = what && *what ? what : "(unnamed)";
    const auto [it, fresh] = label_index.try_emplace(name, labels.size());
    if (fresh)
      labels.push_back(name);
    return it->second;
  }
  void add(Backend b, void* p, std::size_t bytes, const char* what) {
    const std::lock_guard<std::mutex> g(lock);
    const int k = static_cast<int>(b);
    const std::size_t l = intern(what);
    size[p] = {bytes, l};
    if (label_now[k].size() <= l)
      label_now[k].resize(l + 1, 0);
    label_now[k][l] += bytes;
    HeldBytes& h = held[k];
    h.now += bytes;
    if (h.now > h.peak) {
      h.peak = h.now;
      label_at_peak[k] = label_now[k];
    }
  }
  void remove(Backend b, void* p) noexcept {
    const std::lock_guard<std::mutex> g(lock);
    const auto it = size.find(p);
    if (it == size.end())
      return;
    const int k = static_cast<int>(b);
    held[k].now -= it->second.bytes;
    label_now[k][it->second.label] -= it->second.bytes;
    size.erase(it);
  }
};

/// Host memory at a 64-byte alignment (one cache line, and what SIMD loads like).
void* aligned_host(std::size_t bytes, const char* what) {
  void* p = std::aligned_alloc(64, (bytes + 63) / 64 * 64);
  if (!p)
    throw Error(std::string("out of host memory allocating ") + std::to_string(bytes) +
                " bytes for " + what);
  return p;
}

} // namespace

HeldBytes held_bytes(Backend b) {
  Ledger& l = Ledger::get();
  const std::lock_guard<std::mutex> g(l.lock);
  return l.held[static_cast<int>(b)];
}

void reset_peak_bytes(Backend b) {
  Ledger& l = Ledger::get();
  const std::lock_guard<std::mutex> g(l.lock);
  const int k = static_cast<int>(b);
  l.held[k].peak = l.held[k].now;
  l.label_at_peak[k] = l.label_now[k];
}

const char* joined_label(const char* prefix, const char* suffix) {
  static std::mutex lock;
  static std::set<std::string> names; // a set's elements never move
  const std::lock_guard<std::mutex> g(lock);
  return names.insert(std::string(prefix) + "." + suffix).first->c_str();
}

std::vector<LabelledBytes> peak_by_label(Backend b) {
  Ledger& l = Ledger::get();
  const std::lock_guard<std::mutex> g(l.lock);
  const auto& at = l.label_at_peak[static_cast<int>(b)];
  std::vector<LabelledBytes> out;
  for (std::size_t i = 0; i < at.size(); ++i)
    if (at[i] > 0)
      out.push_back({l.labels[i], at[i]});
  std::sort(out.begin(), out.end(), [](const LabelledBytes& a, const LabelledBytes& c) {
    return a.bytes != c.bytes ? a.bytes > c.bytes : a.label < c.label;
  });
  return out;
}

namespace {
/// KF_POISON_ALLOCATIONS=1: every allocation starts as 0xFF bytes (NaN in every float and
/// double, the largest value of every unsigned), so that a value read before anything wrote it
/// shows in the results: the CPU's counterpart of compute-sanitizer initcheck, for the tests
/// (those registered "_poisoned"). Read once per process.
bool poison_allocations() {
  static const bool on = [] {
    const char* v = std::getenv("KF_POISON_ALLOCATIONS");
    return v != nullptr && v[0] == '1';
  }();
  return on;
}
} // namespace

void* alloc_bytes(Backend b, std::size_t bytes, const char* what) {
  if (bytes == 0)
    return nullptr;
  void* p = nullptr;
  if (b == Backend::Cuda) {
#if defined(KF_WITH_CUDA)
    p = cuda_alloc(bytes, what);
#else
    no_cuda(what);
#endif
  } else {
    p = aligned_host(bytes, what);
  }
  if (poison_allocations())
    fill_bytes(b, p, 0xFF, bytes);
  Ledger::get().add(b, p, bytes, what);
  return p;
}

void free_bytes(Backend b, void* p) noexcept {
  if (!p)
    return;
  Ledger::get().remove(b, p);
  if (b == Backend::Cuda) {
#if defined(KF_WITH_CUDA)
    cuda_free(p);
#endif
    return;
  }
  std::free(p);
}

void copy_bytes(void* dst, Backend dst_b, const void* src, Backend src_b, std::size_t bytes) {
  if (bytes == 0)
    return;
  if (dst_b == Backend::Cpu && src_b == Backend::Cpu) {
    KF_EXPECT_WRITTEN(src, bytes);
    std::memcpy(dst, src, bytes);
    return;
  }
#if defined(KF_WITH_CUDA)
  cuda_copy(dst, dst_b == Backend::Cuda, src, src_b == Backend::Cuda, bytes);
#else
  no_cuda("copy_bytes");
#endif
}

void fill_bytes(Backend b, void* p, unsigned char byte, std::size_t bytes) {
  if (bytes == 0)
    return;
  if (b == Backend::Cpu) {
    std::memset(p, byte, bytes);
    return;
  }
#if defined(KF_WITH_CUDA)
  cuda_fill(p, byte, bytes);
#else
  no_cuda("fill_bytes");
#endif
}

void* alloc_host_staging(Backend b, std::size_t bytes, const char* what) {
  if (b == Backend::Cuda) {
#if defined(KF_WITH_CUDA)
    return cuda_alloc_pinned(bytes, what);
#else
    no_cuda(what);
#endif
  }
  return alloc_bytes(Backend::Cpu, bytes, what);
}

void free_host_staging(Backend b, void* p) noexcept {
  if (b == Backend::Cuda) {
#if defined(KF_WITH_CUDA)
    cuda_free_pinned(p);
#endif
    return;
  }
  free_bytes(Backend::Cpu, p);
}

void* alloc_host_readable(Backend b, std::size_t bytes, const char* what) {
  if (bytes == 0)
    return nullptr;
  if (b == Backend::Cuda) {
#if defined(KF_WITH_CUDA)
    return cuda_alloc_pinned(bytes, what);
#else
    no_cuda(what);
#endif
  }
  return aligned_host(bytes, what);
}

void free_host_readable(Backend b, void* p) noexcept {
  if (!p)
    return;
  if (b == Backend::Cuda) {
#if defined(KF_WITH_CUDA)
    cuda_free_pinned(p);
#endif
    return;
  }
  std::free(p);
}

void synchronize(Backend b) {
#if defined(KF_WITH_CUDA)
  if (b == Backend::Cuda)
    cuda_synchronize();
#else
  (void)b;
#endif
}

struct ReadSlot {
  Backend backend;
  std::size_t bytes;
  void* host = nullptr;
  void* event = nullptr; // CUDA: marks the copy's arrival
  bool pending = false;
};

ReadSlot* open_read_slot(Backend b, std::size_t bytes, const char* what) {
  auto* s = new ReadSlot{b, bytes};
  try {
    if (b == Backend::Cuda) {
#if defined(KF_WITH_CUDA)
      s->host = cuda_alloc_pinned(bytes, what);
      s->event = cuda_event_create(what);
#else
      no_cuda(what);
#endif
    } else {
      s->host = alloc_bytes(Backend::Cpu, bytes, what);
    }
  } catch (...) {
    close_read_slot(s);
    throw;
  }
  return s;
}

void close_read_slot(ReadSlot* s) noexcept {
  if (!s)
    return;
#if defined(KF_WITH_CUDA)
  if (s->backend == Backend::Cuda) {
    cuda_event_destroy(s->event);
    cuda_free_pinned(s->host);
    delete s;
    return;
  }
#endif
  free_bytes(Backend::Cpu, s->host);
  delete s;
}

void start_read(ReadSlot* s, const void* src, std::size_t bytes, const char* label) {
  if (bytes > s->bytes)
    throw Error(std::string(label) + ": a read of " + std::to_string(bytes) +
                " bytes into a slot of " + std::to_string(s->bytes));
  if (s->backend == Backend::Cuda) {
#if defined(KF_WITH_CUDA)
    cuda_copy_to_host_async(s->host, src, bytes, s->event, label);
#else
    no_cuda(label);
#endif
  } else if (bytes) {
    std::memcpy(s->host, src, bytes);
  }
  s->pending = true;
}

const void* finish_read(ReadSlot* s, const char* label) {
  if (!s->pending)
    throw Error(std::string(label) + ": waiting for a device read that was never started");
#if defined(KF_WITH_CUDA)
  if (s->backend == Backend::Cuda)
    cuda_event_wait(s->event, label);
#endif
  s->pending = false;
  return s->host;
}

// LSD radix sort, 8 bits a pass, per-thread histograms: stable, O(n) per pass. The particle
// order changes little between steps, so the passes stream through memory.
static void cpu_sort_by_key(std::uint32_t* keys, std::uint32_t* values, std::size_t n,
                            int key_bits) {
  if (n < 2)
    return;
  std::vector<std::uint32_t> k2(n), v2(n);
  std::uint32_t *ks = keys, *vs = values, *kd = k2.data(), *vd = v2.data();
  const int passes = std::max(1, (key_bits + 7) / 8);
#if defined(_OPENMP)
  const int nt = omp_get_max_threads();
#else
  const int nt = 1;
#endif
  std::vector<std::size_t> hist(static_cast<std::size_t>(nt) * 256);
  for (int pass = 0; pass < passes; ++pass) {
    const int shift = 8 * pass;
    std::fill(hist.begin(), hist.end(), 0);
#pragma omp parallel num_threads(nt)
    {
      // The team may be smaller than asked for: split the work by the team actually running.
#if defined(_OPENMP)
      const int t = omp_get_thread_num(), team = omp_get_num_threads();
#else
      const int t = 0, team = 1;
#endif
      const std::size_t lo = n * t / team, hi = n * (t + 1) / team;
      std::size_t* h = &hist[static_cast<std::size_t>(t) * 256];
      for (std::size_t i = lo; i < hi; ++i)
        ++h[(ks[i] >> shift) & 0xFF];
#pragma omp barrier
#pragma omp single
      {
        std::size_t sum = 0; // digit-major, thread-minor order keeps the sort stable
        for (int d = 0; d < 256; ++d)
          for (int tt = 0; tt < team; ++tt) {
            std::size_t c = hist[static_cast<std::size_t>(tt) * 256 + d];
            hist[static_cast<std::size_t>(tt) * 256 + d] = sum;
            sum += c;
          }
      }
      for (std::size_t i = lo; i < hi; ++i) {
        std::size_t pos = h[(ks[i] >> shift) & 0xFF]++;
        kd[pos] = ks[i];
        vd[pos] = vs[i];
      }
    }
    std::swap(ks, kd);
    std::swap(vs, vd);
  }
  if (ks != keys) {
    std::memcpy(keys, ks, n * sizeof(std::uint32_t));
    std::memcpy(values, vs, n * sizeof(std::uint32_t));
  }
}

void sort_by_key(const Exec& ex, std::uint32_t* keys, std::uint32_t* values, std::size_t n,
                 int key_bits, const char* label) {
  if (ex.backend == Backend::Cuda) {
#if defined(KF_WITH_CUDA)
    cuda_sort_by_key(keys, values, n, key_bits, label);
    return;
#else
    no_cuda(label);
#endif
  }
  if (key_bits < 0 || key_bits > 32)
    throw Error(std::string(label) + ": sort_by_key with key_bits=" + std::to_string(key_bits) +
                " (expected 0..32)");
  cpu_sort_by_key(keys, values, n, key_bits);
}

void sort_by_key(const Exec& ex, DeviceBuffer<std::uint32_t>& keys,
                 DeviceBuffer<std::uint32_t>& values, int key_bits, const char* label) {
  if (keys.size() != values.size())
    throw Error(std::string(label) + ": sort_by_key with " + std::to_string(keys.size()) +
                " keys but " + std::to_string(values.size()) + " values");
  sort_by_key(ex, keys.data(), values.data(), keys.size(), key_bits, label);
}

namespace {

/// out[offset[i]] = i where flagged.
struct ScatterFlagged {
  const std::uint32_t* flag;
  const std::uint32_t* offset;
  std::uint32_t* out;
  KF_HD void operator()(std::size_t i) const {
    if (flag[i])
      out[offset[i]] = static_cast<std::uint32_t>(i);
  }
};

} // namespace

std::size_t flagged_indices(const Exec& ex, const DeviceBuffer<std::uint32_t>& flags,
                            DeviceBuffer<std::uint32_t>& offsets, DeviceBuffer<std::uint32_t>& out,
                            const char* label) {
  offsets.resize(flags.size());
  const std::size_t k = exclusive_scan(ex, flags, offsets, label);
  out.resize(k);
  for_each(ex, flags.size(), ScatterFlagged{flags.data(), offsets.data(), out.data()}, label);
  return k;
}

std::uint64_t exclusive_scan(const Exec& ex, const DeviceBuffer<std::uint32_t>& in,
                             DeviceBuffer<std::uint32_t>& out, const char* label) {
  if (out.size() != in.size())
    throw Error(std::string(label) + ": exclusive_scan output size differs from input");
  if (ex.backend == Backend::Cuda) {
#if defined(KF_WITH_CUDA)
    return cuda_exclusive_scan(in, out, label);
#else
    no_cuda(label);
#endif
  }
  std::uint64_t sum = 0;
  const std::uint32_t* a = in.data();
  std::uint32_t* b = out.data();
  for (std::size_t i = 0; i < in.size(); ++i) {
    std::uint32_t v = a[i];
    b[i] = static_cast<std::uint32_t>(sum);
    sum += v;
  }
  return sum;
}

namespace {

struct ScanTotal {
  const std::uint32_t* in;
  const std::uint32_t* out;
  std::size_t n;
  std::uint32_t* total;
  KF_HD void operator()(std::size_t) const { *total = exclusive_scan_total(in, out, n); }
};

} // namespace

void exclusive_scan_on_device(const Exec& ex, const DeviceBuffer<std::uint32_t>& in,
                              DeviceBuffer<std::uint32_t>& out, std::uint32_t* total,
                              const char* label) {
  const std::size_t n = in.size();
  if (out.size() != n)
    throw Error(std::string(label) + ": exclusive_scan_on_device output size differs from input");
  if (n > 0 && out.data() == in.data())
    throw Error(std::string(label) + ": exclusive_scan_on_device in place (the total reads both)");
  if (ex.backend == Backend::Cuda) {
#if defined(KF_WITH_CUDA)
    cuda_exclusive_sum(in.data(), out.data(), n, label); // the scan alone: no total read back
#else
    no_cuda(label);
#endif
  } else {
    exclusive_scan(ex, in, out, label); // on the CPU its total waits for nothing
  }
  if (total)
    for_each(ex, 1, ScanTotal{in.data(), out.data(), n, total}, label);
}

} // namespace kf::exec
