#pragma once
// What the two device transports (NCCL, CUDA IPC) share: a CUDA failure as a one-line kf::Error,
// the check that every buffer is device memory, and the messages a rank sends itself. CUDA build
// only.
#include "comm/Transport.hpp"

#include <cuda_runtime.h>

#include <string>
#include <vector>

namespace kf::comm {

/// Throws "<who>: <call> failed at <file>:<line>: <CUDA error name>: <text>".
[[noreturn]] void throw_cuda(const std::string& who, cudaError_t e, const char* call,
                             const char* file, int line);

/// The file name of a path (full build paths make one-line messages unreadable).
const char* base_name(const char* file);

/// Host memory handed to a device transport faults on the device or hangs; a clear error costs
/// one query per buffer, a few per exchange. `who`: "nccl transport on rank 3".
void require_device_buffers(const std::string& who, std::span<const SendBuffer> sends,
                            std::span<const RecvBuffer> receives);

/// Messages to this rank are device copies on `stream`, paired in order like any peer's (the
/// k-th send to itself with the k-th receive from itself, of equal sizes: a kf::Error if not).
void copy_to_self(const std::string& who, int rank, std::span<const SendBuffer> sends,
                  std::span<const RecvBuffer> receives, cudaStream_t stream);

} // namespace kf::comm
