#pragma once
// The MPI transport: nonblocking point-to-point messages (MPI_Isend/MPI_Irecv, MPI_Waitall) of
// host buffers. The CPU build's only transport, and the GPU build's when ranks share a device on
// several nodes, or where the node refuses CUDA IPC.
#include "comm/Transport.hpp"

namespace kf::comm {

class MpiTransport final : public Transport {
public:
  /// MPI counts are int, so a buffer over `max_message_bytes` travels as several messages of at
  /// most that size (same tag, so MPI's non-overtaking order reassembles them). Tests lower it to
  /// exercise the split without gigabytes of memory. Collective over ctx's communicator.
  explicit MpiTransport(const MpiContext& ctx, std::size_t max_message_bytes = std::size_t(1)
                                                                               << 30);
  ~MpiTransport() override;

  std::string_view name() const override { return "mpi"; }
  MemorySpace memory_space() const override { return MemorySpace::Host; }

private:
  void do_start(std::span<const SendBuffer> sends, std::span<const RecvBuffer> receives) override;
  void do_finish() override;
  /// Ends every request still pending and forgets them, before an error is thrown: posting
  /// failed halfway, or the wait failed.
  void abandon() noexcept;

  /// One posted request: its peer and tag name it in errors; a receive's byte count is checked
  /// against what arrives.
  struct Piece {
    int peer, tag;
    std::size_t bytes;
    bool receive;
  };

  std::size_t max_message_;
  int tag_ub_ = 32767; // the standard's guaranteed minimum; the real bound is read at construction
  std::vector<MPI_Request> requests_; // receive pieces first, then send pieces
  std::vector<Piece> pieces_;         // one per request
  std::vector<MPI_Status> statuses_;
  std::vector<int> ordinal_; // per rank: messages to (or from) it so far in this start()
};

} // namespace kf::comm
