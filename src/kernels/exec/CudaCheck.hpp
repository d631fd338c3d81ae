#pragma once
// CUDA error checks. Every runtime call goes through KF_CUDA(call[, context]); every launch is
// followed by KF_CHECK_LAUNCH(label, n) so a failure names the stage and the problem size.
//
// KF_CUDA's optional second argument is a std::string expression naming what was being done
// ("copying 4096 bytes host->device for 'positions'"); it is evaluated only on failure.
//
// Launch checks are cheap (cudaGetLastError, no sync), so a kernel that faults while running is
// reported by the next synchronising call instead. For debugging, set KF_CUDA_SYNC_CHECK=1 in the
// environment: every launch check then also synchronises, so the fault names its own kernel.
#include <cstddef>
#include <string>

#include <cuda_runtime.h>

namespace kf::exec {

[[noreturn]] void throw_cuda_error(cudaError_t e, const char* what, const char* file, int line);
[[noreturn]] void throw_cuda_error(cudaError_t e, const char* what, const char* file, int line,
                                   const std::string& context);
void check_launch_impl(const char* label, std::size_t n, const char* file, int line);

/// Scratch slots reused across calls, so that no sort, scan or reduction allocates (cudaMalloc and
/// cudaFree synchronise the device, which made small scenes wait on the host every call).
enum class ScratchSlot { Sort, Scan, Reduce, Count };
/// Device memory of at least `bytes` for `slot`, kept between calls and grown (never shrunk)
/// when a caller needs more. All work is on the legacy default stream, so a slot's next user runs
/// after its previous one; callers must not hold the pointer across another call for the slot.
void* cuda_scratch(ScratchSlot slot, std::size_t bytes, const char* label);
/// Whether kernels are launched with programmatic dependent launch: on devices of compute
/// capability 9.0 and later, unless KF_PDL=0 is in the environment. A kernel's blocks are then
/// scheduled while the one before it finishes and wait for it on the device
/// (await_previous_kernel), instead of the GPU draining between the two.
bool launch_overlap();
[[noreturn]] void throw_launch_error(cudaError_t e, const char* label, std::size_t n);

/// Copies `bytes` (a small result, at most 4 KiB) from device memory into host memory `dst`
/// through a page-locked staging buffer, and waits for it.
void cuda_read_result(void* dst, const void* device_src, std::size_t bytes, const char* label);

/// GPU time per kernel label, for finding where a step's time goes (KF_KERNEL_TIMES=1 in the
/// environment; off otherwise, and then free). A scope records a CUDA event before and after the
/// launches it spans; at exit the table is printed to stderr: per label the launches, the GPU
/// time between the events and its share, and how busy the GPU was over the timed span (low
/// means the GPU waited for the host: launch- or wait-bound).
class KernelTimeScope {
public:
  explicit KernelTimeScope(const char* label);
  ~KernelTimeScope();
  KernelTimeScope(const KernelTimeScope&) = delete;
  KernelTimeScope& operator=(const KernelTimeScope&) = delete;

private:
  int slot_ = -1; // its entry among the pending events; -1: not timed (off, or nested)
};

} // namespace kf::exec

#define KF_CUDA(call, ...)                                                                         \
  do {                                                                                             \
    cudaError_t kf_err_ = (call);                                                                  \
    if (kf_err_ != cudaSuccess)                                                                    \
      ::kf::exec::throw_cuda_error(kf_err_, #call, __FILE__, __LINE__ __VA_OPT__(, ) __VA_ARGS__); \
  } while (0)

#define KF_CHECK_LAUNCH(label, n) ::kf::exec::check_launch_impl((label), (n), __FILE__, __LINE__)
