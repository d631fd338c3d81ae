#pragma once
#include <cstddef>
#include <string>
#include <string_view>

namespace kf::exec {

/// Where data lives and kernels run. Every build has Cpu; Cuda exists when built with nvcc.
enum class Backend { Cpu, Cuda };

inline std::string_view to_string(Backend b) {
  return b == Backend::Cpu ? "cpu" : "cuda";
}

/// True when this binary was built with the CUDA backend.
bool cuda_compiled();
/// True when the CUDA backend is compiled in and at least one device is visible.
bool cuda_available();
/// Selects the CUDA device this process uses: its rank-local index modulo the visible devices
/// (more ranks than devices on a node share them round-robin), and returns its CUDA index;
/// -1 on CPU builds.
int cuda_select_device(int local_rank);
/// CUDA devices visible (0 on CPU builds or without one).
int cuda_devices();
/// Free memory of the selected CUDA device in bytes (0 without one).
std::size_t cuda_free_memory_now();
/// One-line description of the device in use ("NVIDIA H100 80GB HBM3, 132 SMs" or "CPU, 2
/// threads").
std::string describe(Backend b);

/// Raw memory on a backend. All host<->device traffic goes through copy_bytes.
void* alloc_bytes(Backend b, std::size_t bytes, const char* what);
void free_bytes(Backend b, void* p) noexcept;
/// Bytes alloc_bytes holds on a backend now, and the most it held at once since
/// reset_peak_bytes (the process's: every buffer of that backend, the CPU's plain host buffers
/// included; a device's page-locked staging is not the device's).
struct HeldBytes {
  std::size_t now = 0, peak = 0;
};
HeldBytes held_bytes(Backend b);
void reset_peak_bytes(Backend b);
void copy_bytes(void* dst, Backend dst_b, const void* src, Backend src_b, std::size_t bytes);
/// Sets `bytes` bytes at p to `byte`, finished on return (poisoning: tests, KF_POISON_ALLOCATIONS).
void fill_bytes(Backend b, void* p, unsigned char byte, std::size_t bytes);
/// Waits until all work queued on the backend is finished (no-op on CPU).
void synchronize(Backend b);
/// Host memory that copies to and from the backend move at full speed: page-locked for a device
/// (a copy from pageable memory is staged through a driver buffer at a fraction of the bus's
/// bandwidth), plain on the CPU.
void* alloc_host_staging(Backend b, std::size_t bytes, const char* what);
void free_host_staging(Backend b, void* p) noexcept;
/// Host memory a kernel of the backend reads in place: page-locked for a device (unified
/// addressing makes its host pointer the device's; each read crosses the bus), plain on the CPU.
/// Outside the backend's ledger (held_bytes): for tables kept whole on the host of which each
/// kernel reads a few rows (HostReadable.hpp).
void* alloc_host_readable(Backend b, std::size_t bytes, const char* what);
void free_host_readable(Backend b, void* p) noexcept;

/// A small device-to-host read that the host collects later (PendingRead.hpp wraps it): page-
/// locked staging memory the copy lands in and an event marking its arrival. On the CPU the copy
/// is made at once.
struct ReadSlot;
ReadSlot* open_read_slot(Backend b, std::size_t bytes, const char* what);
void close_read_slot(ReadSlot* s) noexcept;
/// Queues a copy of `bytes` (at most the slot's) from src, behind the work queued so far.
void start_read(ReadSlot* s, const void* src, std::size_t bytes, const char* label);
/// Waits for the copy start_read queued and returns the staging memory holding it.
const void* finish_read(ReadSlot* s, const char* label);

} // namespace kf::exec
