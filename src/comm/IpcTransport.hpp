#pragma once
// The CUDA IPC transport (CUDA build only), for ranks of one node with a GPU each: a message is
// one copy over NVLink (or PCIe) straight into an inbox the receiving rank exported, and the
// stream order between the ranks is kept by flags in device memory that the GPUs' stream memory
// operations write and wait on. No kernel runs and the host waits for nothing: what NCCL's
// send/recv does with a kernel, its channels and its protocol, here is a copy and two 4-byte
// writes a message. Maxima (max_in_place) still go through NCCL's all-reduce.
//
// For each ordered pair (A sends to B):
//   B owns an inbox for A's messages of an exchange (cudaMalloc, exported by cudaIpcGetMemHandle
//   and opened once by A) and a flag block: ready[A], the count of A's messages in the inbox,
//   and ack[A], the count of B's messages A has read out of its inbox on A.
//   A, at its k-th exchange with a message to B, on its stream: waits until ack[B] on A >= k - 1
//   (B has read the last one out of the inbox), copies every message to B into the inbox, one
//   after the other, and writes ready[A] on B = k. B, at its k-th exchange with a message from
//   A: waits until ready[A] on B >= k, copies the messages out into the caller's buffers and
//   writes ack[B] on A = k.
// The counts are the same on both sides because both know the sizes (the transport's matching
// rule). An inbox too small for an exchange's bytes grows on both sides at once (both compare
// the same total with the same capacity): its owner allocates a larger one and sends the handle
// over MPI; the old one is freed at destruction, after every peer has closed it.
#include "comm/NcclTransport.hpp"
#include "comm/Transport.hpp"

#include <cuda_runtime.h>

#include <memory>
#include <vector>

namespace kf::comm {

class IpcTransport final : public Transport {
public:
  /// Collective over ctx's communicator, whose ranks must all run on one node with a GPU each
  /// (make_transport checks): makes `device` current, exports this rank's flag block and opens
  /// every peer's, builds the NCCL communicator for max_in_place. Work is queued on `stream`
  /// (null: a non-blocking stream of its own at the highest priority). A rank that cannot (no
  /// stream memory operations, an IPC handle that does not open) is a kf::Error on every rank.
  IpcTransport(const MpiContext& ctx, int device, cudaStream_t stream);
  ~IpcTransport() override;

  std::string_view name() const override { return "ipc"; }
  MemorySpace memory_space() const override { return MemorySpace::Device; }

private:
  void do_start(std::span<const SendBuffer> sends, std::span<const RecvBuffer> receives) override;
  /// Orders the legacy default stream after the exchange by an event (no host wait).
  void do_finish() override;
  void do_max_in_place(void* data, std::size_t n, bool is_double) override;

  /// Grows the inboxes this exchange needs larger: `in_bytes[p]` arrive from p, `out_bytes[p]`
  /// leave for p (0 where none). Pairwise over MPI, only where an inbox grows.
  void grow_inboxes(const std::vector<std::size_t>& in_bytes,
                    const std::vector<std::size_t>& out_bytes);
  void wait_at_least(const std::uint32_t* flag, std::uint32_t value);
  void write(std::uint32_t* flag, std::uint32_t value);

  /// What this rank keeps for each other rank p.
  struct Peer {
    void* inbox = nullptr; // here, for p's messages
    std::size_t inbox_bytes = 0;
    void* outbox = nullptr; // p's inbox for this rank's messages, opened here
    std::size_t outbox_bytes = 0;
    std::uint32_t* flags = nullptr; // p's flag block, opened here
    std::uint32_t sent = 0, received = 0;
  };

  int device_;
  cudaStream_t stream_;
  bool own_stream_ = false;
  cudaEvent_t filled_ = nullptr, moved_ = nullptr;
  // This rank's flag block: ready[p] at [p], ack[p] at [size + p].
  std::uint32_t* flags_ = nullptr;
  std::vector<Peer> peers_;    // by rank; this rank's entry unused
  std::vector<void*> retired_; // inboxes outgrown, freed at destruction
  std::unique_ptr<NcclTransport> reduce_;
  void* wait_value_ = nullptr;  // cuStreamWaitValue32, through the runtime's driver entry point
  void* write_value_ = nullptr; // cuStreamWriteValue32
};

} // namespace kf::comm
