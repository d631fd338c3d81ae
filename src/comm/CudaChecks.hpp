#pragma once
// CUDA checks shared by the device transports (CUDA build only): a failed call becomes a
// kf::Error naming the transport, the call and where; host memory handed to a transport that
// moves device buffers is refused with a clear error instead of a fault or a hang.
#include "core/Error.hpp"

#include <cuda_runtime.h>

#include <cstring>
#include <string>
#include <string_view>

namespace kf::comm::cuda_checks {

// Keeps only the file name: full build paths make one-line messages unreadable.
inline const char* base_name(const char* file) {
  const char* slash = std::strrchr(file, '/');
  return slash ? slash + 1 : file;
}

[[noreturn]] inline void throw_cuda(std::string_view who, cudaError_t e, const char* call,
                                    const char* file, int line) {
  throw Error(std::string(who) + " transport: " + call + " failed at " + base_name(file) + ":" +
              std::to_string(line) + ": " + cudaGetErrorName(e) + ": " + cudaGetErrorString(e));
}

/// A kf::Error unless `p` (bytes > 0) is device (or managed) memory; `what` is "send" or
/// "receive", `peer` the rank it goes to or comes from. One query a buffer, a few an exchange.
inline void require_device_memory(std::string_view who, int rank, const void* p, std::size_t bytes,
                                  const char* what, int peer) {
  if (bytes == 0)
    return;
  cudaPointerAttributes a{};
  const cudaError_t e = cudaPointerGetAttributes(&a, p);
  if (e != cudaSuccess)
    throw_cuda(who, e, "cudaPointerGetAttributes", __FILE__, __LINE__);
  if (a.type != cudaMemoryTypeDevice && a.type != cudaMemoryTypeManaged)
    throw Error(std::string(who) + " transport on rank " + std::to_string(rank) + ": the " + what +
                " buffer for rank " + std::to_string(peer) + " is host memory; the " +
                std::string(who) +
                " transport moves device buffers (stage through the device, or use the mpi "
                "transport)");
}

} // namespace kf::comm::cuda_checks
