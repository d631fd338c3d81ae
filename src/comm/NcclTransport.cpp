#include "comm/NcclTransport.hpp"

#include "comm/DeviceMessages.hpp"
#include "core/Error.hpp"

namespace kf::comm {

namespace {

[[noreturn]] void throw_nccl(ncclResult_t r, ncclComm_t comm, const char* call, const char* file,
                             int line) {
  std::string text = std::string("nccl transport: ") + call + " failed at " + base_name(file) +
                     ":" + std::to_string(line) + ": " + ncclGetErrorString(r);
#if defined(NCCL_VERSION_CODE) && NCCL_VERSION_CODE >= NCCL_VERSION(2, 13, 0)
  // NCCL's own last message usually says which peer or resource failed.
  const char* last = ncclGetLastError(comm);
  if (last != nullptr && last[0] != '\0')
    text += std::string(" (") + last + ")";
#else
  (void)comm;
#endif
  throw Error(text);
}

} // namespace

// Local to comm (kernels' KF_CUDA lives in a layer comm does not depend on).
#define KF_COMM_NCCL(call)                                                                         \
  do {                                                                                             \
    const ncclResult_t kf_r_ = (call);                                                             \
    if (kf_r_ != ncclSuccess)                                                                      \
      throw_nccl(kf_r_, nccl_, #call, __FILE__, __LINE__);                                         \
  } while (0)

#define KF_COMM_CUDA(call)                                                                         \
  do {                                                                                             \
    const cudaError_t kf_e_ = (call);                                                              \
    if (kf_e_ != cudaSuccess)                                                                      \
      throw_cuda("nccl transport", kf_e_, #call, __FILE__, __LINE__);                              \
  } while (0)

NcclTransport::NcclTransport(const MpiContext& ctx, int device, cudaStream_t stream)
    : Transport(ctx), device_(device), stream_(stream) {
  // A failure on one rank must not leave the others waiting in ncclCommInitRank: the steps that
  // can fail locally report to every rank before the communicator is built.
  std::string local_error;
  const cudaError_t set = cudaSetDevice(device_);
  if (set != cudaSuccess) {
    local_error = "cudaSetDevice(" + std::to_string(device_) + "): " + cudaGetErrorName(set) +
                  ": " + cudaGetErrorString(set);
    (void)cudaGetLastError();
  }
  struct {
    int ok;
    ncclUniqueId id;
  } root{1, {}};
  if (rank() == 0) {
    const ncclResult_t r = local_error.empty() ? ncclGetUniqueId(&root.id) : ncclSuccess;
    if (r != ncclSuccess)
      local_error = std::string("ncclGetUniqueId: ") + ncclGetErrorString(r);
    root.ok = local_error.empty();
  }
  check_mpi(MPI_Bcast(&root, int(sizeof root), MPI_BYTE, 0, comm()),
            "broadcasting the NCCL unique id");
  int ok = local_error.empty(), all_ok = 0;
  check_mpi(MPI_Allreduce(&ok, &all_ok, 1, MPI_INT, MPI_MIN, comm()),
            "agreeing that every rank can start NCCL");
  if (!all_ok)
    throw Error(
        "nccl transport on rank " + std::to_string(rank()) + ": " +
        (local_error.empty() ? std::string("another rank failed to set up its GPU") : local_error));
  KF_COMM_NCCL(ncclCommInitRank(&nccl_, size(), root.id, rank()));
  if (!stream_) {
    // The highest priority: the interior's kernels fill every SM, and the messages' kernels
    // would otherwise wait for blocks of theirs to retire.
    int least = 0, greatest = 0;
    KF_COMM_CUDA(cudaDeviceGetStreamPriorityRange(&least, &greatest));
    KF_COMM_CUDA(cudaStreamCreateWithPriority(&stream_, cudaStreamNonBlocking, greatest));
    own_stream_ = true;
  }
  KF_COMM_CUDA(cudaEventCreateWithFlags(&filled_, cudaEventDisableTiming));
  KF_COMM_CUDA(cudaEventCreateWithFlags(&moved_, cudaEventDisableTiming));
}

NcclTransport::~NcclTransport() {
  finish_quietly();
  if (stream_) // the last exchange done before its communicator and events go
    (void)cudaStreamSynchronize(stream_);
  if (moved_)
    (void)cudaEventDestroy(moved_);
  if (nccl_ != nullptr)
    (void)ncclCommDestroy(nccl_);
  if (filled_)
    (void)cudaEventDestroy(filled_);
  if (own_stream_)
    (void)cudaStreamDestroy(stream_);
}

void NcclTransport::do_start(std::span<const SendBuffer> sends,
                             std::span<const RecvBuffer> receives) {
  const std::string who = "nccl transport on rank " + std::to_string(rank());
  require_device_buffers(who, sends, receives);

  // The send buffers are filled by kernels on the legacy default stream (and the receive buffers
  // read by the last exchange's unpacking there): NCCL's stream waits for them on the device.
  KF_COMM_CUDA(cudaEventRecord(filled_, cudaStreamLegacy));
  KF_COMM_CUDA(cudaStreamWaitEvent(stream_, filled_, 0));

  copy_to_self(who, rank(), sends, receives, stream_);

  // NCCL has no tags: operations between two ranks within a group run in the order they were
  // issued, which pairs the k-th send with the k-th receive. Empty messages are skipped on both
  // sides (their sizes agree), which keeps that pairing and avoids NCCL's history of zero-count
  // bugs.
  KF_COMM_NCCL(ncclGroupStart());
  try {
    for (const RecvBuffer& r : receives)
      if (r.peer != rank() && r.bytes > 0)
        KF_COMM_NCCL(ncclRecv(r.data, r.bytes, ncclUint8, r.peer, nccl_, stream_));
    for (const SendBuffer& s : sends)
      if (s.peer != rank() && s.bytes > 0)
        KF_COMM_NCCL(ncclSend(s.data, s.bytes, ncclUint8, s.peer, nccl_, stream_));
  } catch (...) {
    (void)ncclGroupEnd(); // never leave a group open: the next NCCL call would join it
    throw;
  }
  KF_COMM_NCCL(ncclGroupEnd());
}

void NcclTransport::do_finish() {
  // The unpacking kernels and everything after them on the legacy default stream wait for the
  // messages on the device; a host wait here cost a round trip per refresh (three a step).
  KF_COMM_CUDA(cudaEventRecord(moved_, stream_));
  KF_COMM_CUDA(cudaStreamWaitEvent(cudaStreamLegacy, moved_, 0));
  ncclResult_t async = ncclSuccess;
  KF_COMM_NCCL(ncclCommGetAsyncError(nccl_, &async));
  if (async != ncclSuccess)
    throw_nccl(async, nccl_, "an exchange (ncclCommGetAsyncError)", __FILE__, __LINE__);
}

void NcclTransport::do_max_in_place(void* data, std::size_t n, bool is_double) {
  if (n == 0)
    return;
  KF_COMM_CUDA(cudaEventRecord(filled_, cudaStreamLegacy));
  KF_COMM_CUDA(cudaStreamWaitEvent(stream_, filled_, 0));
  KF_COMM_NCCL(
      ncclAllReduce(data, data, n, is_double ? ncclDouble : ncclFloat, ncclMax, nccl_, stream_));
  KF_COMM_CUDA(cudaEventRecord(moved_, stream_));
  KF_COMM_CUDA(cudaStreamWaitEvent(cudaStreamLegacy, moved_, 0));
}

} // namespace kf::comm
