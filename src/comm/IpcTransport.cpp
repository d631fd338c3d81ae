#include "comm/IpcTransport.hpp"

#include "comm/CudaChecks.hpp"
#include "core/Error.hpp"

#include <cuda.h> // the stream memory operations' types only: the functions come through cudart

#include <algorithm>
#include <cstring>

namespace kf::comm {

namespace {

using WaitValue32 = CUresult (*)(CUstream, CUdeviceptr, cuuint32_t, unsigned int);
using WriteValue32 = CUresult (*)(CUstream, CUdeviceptr, cuuint32_t, unsigned int);

// An inbox's handle travels with its capacity.
struct InboxHandle {
  cudaIpcMemHandle_t handle;
  std::uint64_t bytes;
};

// The inboxes' handles on a tag of their own (no data goes over MPI here; kSizesTag is 0).
constexpr int kInboxTag = 1;

// Capacity for `need` bytes: a quarter more, so that a halo growing by a few rows does not
// reallocate at every rebuild, and at least 256 KiB.
std::size_t inbox_capacity(std::size_t need) {
  const std::size_t grain = std::size_t(64) << 10;
  const std::size_t want = std::max(need + need / 4, std::size_t(256) << 10);
  return (want + grain - 1) / grain * grain;
}

void* driver_entry(const char* symbol) {
  void* fn = nullptr;
  cudaDriverEntryPointQueryResult found{};
  const cudaError_t e =
      cudaGetDriverEntryPointByVersion(symbol, &fn, 12000, cudaEnableDefault, &found);
  if (e != cudaSuccess || found != cudaDriverEntryPointSuccess || fn == nullptr) {
    (void)cudaGetLastError();
    return nullptr;
  }
  return fn;
}

} // namespace

#define KF_COMM_CUDA(call)                                                                         \
  do {                                                                                             \
    const cudaError_t kf_e_ = (call);                                                              \
    if (kf_e_ != cudaSuccess)                                                                      \
      cuda_checks::throw_cuda("ipc", kf_e_, #call, __FILE__, __LINE__);                            \
  } while (0)

IpcTransport::IpcTransport(const MpiContext& ctx, int device, cudaStream_t stream)
    : Transport(ctx), device_(device), stream_(stream), peers_(std::size_t(ctx.size())) {
  // Every step that can fail on one rank reports to all before anything collective waits on it.
  std::string local_error;
  auto note = [&](cudaError_t e, const std::string& what) {
    if (e != cudaSuccess && local_error.empty())
      local_error = what + ": " + cudaGetErrorName(e) + ": " + cudaGetErrorString(e);
    (void)cudaGetLastError();
  };
  auto agree = [&](const std::string& step) {
    int ok = local_error.empty(), all_ok = 0;
    check_mpi(MPI_Allreduce(&ok, &all_ok, 1, MPI_INT, MPI_MIN, comm()), "agreeing on " + step);
    if (!all_ok)
      throw Error("ipc transport on rank " + std::to_string(rank()) + ": " +
                  (local_error.empty() ? "another rank failed " + step : local_error));
  };

  note(cudaSetDevice(device_), "cudaSetDevice(" + std::to_string(device_) + ")");
  wait_value_ = driver_entry("cuStreamWaitValue32");
  write_value_ = driver_entry("cuStreamWriteValue32");
  if (local_error.empty() && (!wait_value_ || !write_value_))
    local_error = "the driver has no stream memory operations (cuStreamWaitValue32)";
  const std::size_t flag_bytes = 2 * std::size_t(size()) * sizeof(std::uint32_t);
  if (local_error.empty()) {
    note(cudaMalloc(reinterpret_cast<void**>(&flags_), flag_bytes), "cudaMalloc (flags)");
    if (flags_)
      note(cudaMemset(flags_, 0, flag_bytes), "cudaMemset (flags)");
  }
  if (local_error.empty() && !stream_) {
    // The highest priority, as NCCL's: the copies wait for nothing the interior's kernels hold.
    int least = 0, greatest = 0;
    note(cudaDeviceGetStreamPriorityRange(&least, &greatest), "cudaDeviceGetStreamPriorityRange");
    note(cudaStreamCreateWithPriority(&stream_, cudaStreamNonBlocking, greatest),
         "cudaStreamCreateWithPriority");
    own_stream_ = stream_ != nullptr;
  }
  if (local_error.empty()) {
    note(cudaEventCreateWithFlags(&filled_, cudaEventDisableTiming), "cudaEventCreate");
    note(cudaEventCreateWithFlags(&moved_, cudaEventDisableTiming), "cudaEventCreate");
  }
  if (local_error.empty()) { // the stream memory operations work here (a write to our own flag)
    const CUresult r = reinterpret_cast<WriteValue32>(write_value_)(
        reinterpret_cast<CUstream>(stream_), reinterpret_cast<CUdeviceptr>(flags_), 0, 0);
    if (r != CUDA_SUCCESS)
      local_error = "cuStreamWriteValue32 failed (error " + std::to_string(int(r)) +
                    "): this GPU or driver has no stream memory operations";
    else
      note(cudaStreamSynchronize(stream_), "cudaStreamSynchronize");
  }
  cudaIpcMemHandle_t mine{};
  if (local_error.empty())
    note(cudaIpcGetMemHandle(&mine, flags_), "cudaIpcGetMemHandle (flags)");
  agree("setting up its GPU");

  // Every rank's flag block, opened by every other rank.
  std::vector<cudaIpcMemHandle_t> all(static_cast<std::size_t>(size()));
  check_mpi(MPI_Allgather(&mine, int(sizeof mine), MPI_BYTE, all.data(), int(sizeof mine), MPI_BYTE,
                          comm()),
            "gathering the flag blocks' handles");
  for (int p = 0; p < size() && local_error.empty(); ++p)
    if (p != rank()) {
      void* opened = nullptr;
      note(cudaIpcOpenMemHandle(&opened, all[std::size_t(p)], cudaIpcMemLazyEnablePeerAccess),
           "opening rank " + std::to_string(p) +
               "'s flags (cudaIpcOpenMemHandle: its GPU must "
               "be reachable from this one)");
      peers_[std::size_t(p)].flags = static_cast<std::uint32_t*>(opened);
    }
  agree("opening its peers' memory");
  reduce_ = std::make_unique<NcclTransport>(ctx, device_, stream_);
}

IpcTransport::~IpcTransport() {
  finish_quietly();
  if (stream_)
    (void)cudaStreamSynchronize(stream_);
  reduce_.reset();
  // Every rank closes what it opened before any rank frees what it exported.
  for (Peer& p : peers_) {
    if (p.flags)
      (void)cudaIpcCloseMemHandle(p.flags);
    if (p.outbox)
      (void)cudaIpcCloseMemHandle(p.outbox);
  }
  int finalized = 0;
  MPI_Finalized(&finalized);
  if (!finalized)
    (void)MPI_Barrier(comm());
  for (Peer& p : peers_)
    if (p.inbox)
      (void)cudaFree(p.inbox);
  for (void* r : retired_)
    (void)cudaFree(r);
  if (flags_)
    (void)cudaFree(flags_);
  if (filled_)
    (void)cudaEventDestroy(filled_);
  if (moved_)
    (void)cudaEventDestroy(moved_);
  if (own_stream_)
    (void)cudaStreamDestroy(stream_);
}

void IpcTransport::wait_at_least(const std::uint32_t* flag, std::uint32_t value) {
  // CU_STREAM_WAIT_VALUE_GEQ: a cyclic >=, so the counts may wrap.
  const CUresult r = reinterpret_cast<WaitValue32>(wait_value_)(reinterpret_cast<CUstream>(stream_),
                                                                reinterpret_cast<CUdeviceptr>(flag),
                                                                value, CU_STREAM_WAIT_VALUE_GEQ);
  if (r != CUDA_SUCCESS)
    throw Error("ipc transport on rank " + std::to_string(rank()) +
                ": cuStreamWaitValue32 failed (error " + std::to_string(int(r)) + ")");
}

void IpcTransport::write(std::uint32_t* flag, std::uint32_t value) {
  // The default flags keep a memory barrier before the write: the copies queued before it on
  // this stream are visible to the peer when it sees the value.
  const CUresult r = reinterpret_cast<WriteValue32>(write_value_)(
      reinterpret_cast<CUstream>(stream_), reinterpret_cast<CUdeviceptr>(flag), value, 0);
  if (r != CUDA_SUCCESS)
    throw Error("ipc transport on rank " + std::to_string(rank()) +
                ": cuStreamWriteValue32 failed (error " + std::to_string(int(r)) + ")");
}

void IpcTransport::grow_inboxes(const std::vector<std::size_t>& in_bytes,
                                const std::vector<std::size_t>& out_bytes) {
  std::vector<int> grow_here, grow_there;
  for (int p = 0; p < size(); ++p) {
    if (p == rank())
      continue;
    if (in_bytes[std::size_t(p)] > peers_[std::size_t(p)].inbox_bytes)
      grow_here.push_back(p);
    if (out_bytes[std::size_t(p)] > peers_[std::size_t(p)].outbox_bytes)
      grow_there.push_back(p);
  }
  if (grow_here.empty() && grow_there.empty())
    return;
  // The messages queued so far into and out of the old boxes are done before they change.
  KF_COMM_CUDA(cudaStreamSynchronize(stream_));
  std::vector<InboxHandle> sent(grow_here.size()), got(grow_there.size());
  for (std::size_t i = 0; i < grow_here.size(); ++i) {
    Peer& p = peers_[std::size_t(grow_here[i])];
    const std::size_t bytes = inbox_capacity(in_bytes[std::size_t(grow_here[i])]);
    void* box = nullptr;
    KF_COMM_CUDA(cudaMalloc(&box, bytes));
    if (p.inbox)
      retired_.push_back(p.inbox); // the peer may still have it open
    p.inbox = box;
    p.inbox_bytes = bytes;
    KF_COMM_CUDA(cudaIpcGetMemHandle(&sent[i].handle, box));
    sent[i].bytes = bytes;
  }
  std::vector<SendBuffer> sends;
  std::vector<RecvBuffer> receives;
  for (std::size_t i = 0; i < grow_here.size(); ++i)
    sends.push_back({grow_here[i], &sent[i], sizeof(InboxHandle)});
  for (std::size_t i = 0; i < grow_there.size(); ++i)
    receives.push_back({grow_there[i], &got[i], sizeof(InboxHandle)});
  post_and_wait(sends, receives, kInboxTag,
                "ipc transport on rank " + std::to_string(rank()) + ": the inboxes' handles");
  for (std::size_t i = 0; i < grow_there.size(); ++i) {
    Peer& p = peers_[std::size_t(grow_there[i])];
    if (p.outbox)
      KF_COMM_CUDA(cudaIpcCloseMemHandle(p.outbox));
    p.outbox = nullptr;
    KF_COMM_CUDA(cudaIpcOpenMemHandle(&p.outbox, got[i].handle, cudaIpcMemLazyEnablePeerAccess));
    p.outbox_bytes = std::size_t(got[i].bytes);
  }
}

void IpcTransport::do_start(std::span<const SendBuffer> sends,
                            std::span<const RecvBuffer> receives) {
  for (const SendBuffer& s : sends)
    cuda_checks::require_device_memory("ipc", rank(), s.data, s.bytes, "send", s.peer);
  for (const RecvBuffer& r : receives)
    cuda_checks::require_device_memory("ipc", rank(), r.data, r.bytes, "receive", r.peer);
  const auto self = self_messages(sends, receives);

  const std::size_t n = std::size_t(size());
  std::vector<std::size_t> in_bytes(n, 0), out_bytes(n, 0);
  for (const SendBuffer& s : sends)
    if (s.peer != rank())
      out_bytes[std::size_t(s.peer)] += s.bytes;
  for (const RecvBuffer& r : receives)
    if (r.peer != rank())
      in_bytes[std::size_t(r.peer)] += r.bytes;
  grow_inboxes(in_bytes, out_bytes);

  // The send buffers are filled (and the last exchange's receives read) by work queued on the
  // legacy default stream: this stream waits for it on the device.
  KF_COMM_CUDA(cudaEventRecord(filled_, cudaStreamLegacy));
  KF_COMM_CUDA(cudaStreamWaitEvent(stream_, filled_, 0));
  for (const auto& [out, in] : self)
    if (out->bytes > 0)
      KF_COMM_CUDA(
          cudaMemcpyAsync(in->data, out->data, out->bytes, cudaMemcpyDeviceToDevice, stream_));

  const std::uint32_t me = std::uint32_t(rank());
  // Sends first: the peers' waits for them are what bounds the exchange.
  for (int q = 0; q < size(); ++q) {
    Peer& p = peers_[std::size_t(q)];
    if (q == rank() || out_bytes[std::size_t(q)] == 0)
      continue;
    const std::uint32_t k = ++p.sent;
    if (k != 1) // the peer has read the last message out of its inbox
      wait_at_least(flags_ + n + std::size_t(q), k - 1);
    std::size_t at = 0;
    for (const SendBuffer& s : sends)
      if (s.peer == q && s.bytes > 0) {
        KF_COMM_CUDA(cudaMemcpyAsync(static_cast<char*>(p.outbox) + at, s.data, s.bytes,
                                     cudaMemcpyDeviceToDevice, stream_));
        at += s.bytes;
      }
    write(p.flags + me, k); // ready[me] on q
  }
  for (int q = 0; q < size(); ++q) {
    Peer& p = peers_[std::size_t(q)];
    if (q == rank() || in_bytes[std::size_t(q)] == 0)
      continue;
    const std::uint32_t k = ++p.received;
    wait_at_least(flags_ + std::size_t(q), k);
    std::size_t at = 0;
    for (const RecvBuffer& r : receives)
      if (r.peer == q && r.bytes > 0) {
        KF_COMM_CUDA(cudaMemcpyAsync(r.data, static_cast<const char*>(p.inbox) + at, r.bytes,
                                     cudaMemcpyDeviceToDevice, stream_));
        at += r.bytes;
      }
    write(p.flags + n + me, k); // ack[me] on q
  }
}

void IpcTransport::do_finish() {
  KF_COMM_CUDA(cudaEventRecord(moved_, stream_));
  KF_COMM_CUDA(cudaStreamWaitEvent(cudaStreamLegacy, moved_, 0));
}

void IpcTransport::do_max_in_place(void* data, std::size_t n, bool is_double) {
  if (is_double)
    reduce_->max_in_place(static_cast<double*>(data), n);
  else
    reduce_->max_in_place(static_cast<float*>(data), n);
}

} // namespace kf::comm
