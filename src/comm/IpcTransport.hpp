#pragma once
// The CUDA IPC transport (CUDA build only): for ranks of one node whose GPUs are shared (NCCL
// refuses two ranks on one device), so that their messages need not cross to the host and back.
// Each rank keeps a mailbox in its device memory for every peer that sends to it, two used in
// turn, exported through cudaIpcGetMemHandle when it is made or grows. A sender copies its packed
// buffers device to device into the peer's mailbox on a stream of its own and records an
// interprocess event; the receiver's stream waits for that event, then copies the message out.
// The hosts pass only small MPI notes (the mailbox is free, and its handle when it grew; the
// copy is queued): neither host waits for the other's device work, as with NCCL.
#include "comm/Transport.hpp"

#include <cuda_runtime.h>

#include <cstdint>
#include <map>
#include <vector>

namespace kf::comm {

class IpcTransport final : public Transport {
public:
  /// Collective over ctx's communicator, whose ranks must all run on one node with a GPU each
  /// (shared or not). Opens every other rank's interprocess events and a probe of its memory:
  /// where the node refuses (a container without a shared IPC namespace, say) it throws a
  /// kf::Error on every rank alike, saying why. Work is queued on `stream` (null: a non-blocking
  /// stream of its own, of the highest priority), ordered after the legacy default stream's work
  /// before start() and before its work after finish() by events, as NcclTransport does.
  IpcTransport(const MpiContext& ctx, cudaStream_t stream);
  ~IpcTransport() override;

  std::string_view name() const override { return "ipc"; }
  MemorySpace memory_space() const override { return MemorySpace::Device; }

private:
  /// What a receiver tells a sender at each exchange: its mailbox for this exchange is free, how
  /// large it is, and its handle when it is new (the sender then opens it, closing the old).
  struct ReadyNote {
    std::uint64_t capacity = 0;
    std::uint64_t fresh = 0;
    cudaIpcMemHandle_t handle{};
  };
  /// A mailbox this rank owns (peer -> this rank) or has opened (this rank -> peer).
  struct Mailbox {
    unsigned char* data = nullptr;
    std::size_t capacity = 0;
    cudaIpcMemHandle_t handle{};
    std::vector<unsigned char*> retired; // owned, outgrown: freed once the sender let them go
    cudaEvent_t drained = nullptr;       // owned: the last copy out of it, on stream_
  };
  /// The messages to or from one peer in one exchange, in the order given.
  struct Group {
    int peer = -1;
    std::size_t total = 0;
    std::vector<SendBuffer> sends;
    std::vector<RecvBuffer> receives;
    bool copied = false; // sends: queued into the peer's mailbox
  };

  void do_start(std::span<const SendBuffer> sends, std::span<const RecvBuffer> receives) override;
  void do_finish() override;
  /// Device data: staged through the host around an MPI all-reduce (a few values a step).
  void do_max_in_place(void* data, std::size_t n, bool is_double) override;

  /// Queues send group g's copies into its peer's mailbox, the event after them, and the note
  /// that they are queued.
  void copy_out(std::size_t g);
  /// The owned mailbox (peer -> this rank) of this exchange, at least `bytes` large.
  Mailbox& inbox(int peer, std::size_t bytes, ReadyNote& note);
  /// Everything this rank owns or opened, released (the peers having released theirs first where
  /// `peers_done`).
  void release(bool peers_done) noexcept;
  [[noreturn]] void fail(const std::string& what) const;

  int device_ = -1;
  cudaStream_t stream_ = nullptr;
  bool own_stream_ = false;
  cudaEvent_t filled_ = nullptr;         // the default stream's work before start()
  cudaEvent_t moved_ = nullptr;          // the exchange's end on stream_
  std::vector<cudaEvent_t> copied_;      // [peer]: this rank's copies into its mailbox (exported)
  std::vector<cudaEvent_t> peer_copied_; // [peer]: its copies into this rank's mailbox (imported)
  // Mailboxes by (peer, parity): the parity of the exchanges so far between the two in that
  // direction, which both sides count alike (each send to a peer is a receive of it).
  std::map<std::pair<int, int>, Mailbox> inboxes_, outboxes_;
  std::vector<std::uint64_t> sent_count_, received_count_; // [peer]: exchanges so far
  // The exchange in flight.
  std::vector<Group> send_groups_, recv_groups_;
  std::vector<ReadyNote> ready_out_, ready_in_;
  std::vector<std::uint64_t> sent_out_, sent_in_; // bytes queued (checked against the receive)
  std::vector<MPI_Request> ready_out_req_, ready_in_req_, sent_out_req_, sent_in_req_;
};

} // namespace kf::comm
