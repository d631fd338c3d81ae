#pragma once
// Moves packed byte buffers between neighbour ranks (halos, migration). One interface, three
// transports: MPI for host buffers; in the CUDA build, NCCL for device buffers where every rank has
// a GPU of its own, CUDA IPC where ranks of one node share GPUs. Knows nothing of physics: the
// caller packs and unpacks.
//
// Matching rule: the k-th send from rank A to rank B in A's `start` is received by the k-th receive
// from A in B's `start`, and both must name the same byte count (exchange_sizes tells a receiver
// the counts beforehand). Sends and receives may name the caller's own rank. A disagreement is
// reported where the transport can see it (MPI: a short message, or MPI_ERR_TRUNCATE), but it is
// a caller's bug, not a safety net: Open MPI 4.1 writes past a truncated receive of a large message
// before reporting it, and NCCL cannot tell at all.
#include "comm/MpiContext.hpp"

#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

struct CUstream_st; // cudaStream_t without the CUDA headers, so CPU builds never see them

namespace kf::comm {

/// Where a transport's buffers must live.
enum class MemorySpace { Host, Device };

enum class TransportKind { Auto, Mpi, Nccl, Ipc };

std::string_view to_string(MemorySpace s);
std::string_view to_string(TransportKind k);
/// "auto", "mpi", "nccl" or "ipc"; anything else is a kf::Error naming the choices.
TransportKind parse_transport_kind(std::string_view text);

struct SendBuffer {
  int peer = -1;
  const void* data = nullptr; // may be null when bytes == 0
  std::size_t bytes = 0;
};

struct RecvBuffer {
  int peer = -1;
  void* data = nullptr; // may be null when bytes == 0
  std::size_t bytes = 0;
};

class Transport {
public:
  Transport(const Transport&) = delete;
  Transport& operator=(const Transport&) = delete;
  virtual ~Transport();

  /// "mpi", "nccl" or "ipc".
  virtual std::string_view name() const = 0;
  /// Where the buffers given to start() must live.
  virtual MemorySpace memory_space() const = 0;

  /// Posts every send and receive and returns at once, so the caller can compute while they move.
  /// The buffers must stay untouched (sends) or unread (receives) until finish() returns. One
  /// exchange at a time: starting while another is in flight is an error. Empty lists are fine.
  void start(std::span<const SendBuffer> sends, std::span<const RecvBuffer> receives);
  /// Waits for everything start() posted; then the receive buffers hold the data (NCCL: for the
  /// work queued on the legacy default stream after it, without a host wait). A no-op when
  /// nothing is in flight. A failure (MPI, NCCL or CUDA, or a size mismatch MPI can see) is a
  /// kf::Error, and the transport is then idle again.
  void finish();
  bool in_flight() const { return in_flight_; }

  /// What each of `peers` sends this rank, given what this rank sends each of them
  /// (send_bytes[i] goes to peers[i]). Only neighbours talk: the peer relation must be symmetric
  /// (if A lists B, B lists A), peers distinct. Always over MPI (host counts), whatever the
  /// transport, and independent of an exchange in flight. Collective over the listed peers.
  std::vector<std::uint64_t> exchange_sizes(std::span<const int> peers,
                                            std::span<const std::uint64_t> send_bytes) const;

  /// Moves host buffers between neighbours and waits (sends[i] and receives[i] name peers; the
  /// sizes agreed beforehand): always over MPI, on a tag of its own, whatever the transport, for
  /// small host-side exchanges (the knit ghosts' sums back to their owners). Not while an
  /// exchange is in flight; collective over the peers named.
  void exchange_host(std::span<const SendBuffer> sends, std::span<const RecvBuffer> receives) const;

  /// Replaces each of the n values at `data` (in memory_space()) by its largest over the job, in
  /// place: an all-reduce. NaN is the caller's to replace first (how NaN compares is the
  /// transport's). NCCL queues it on its stream after the work queued before on the legacy
  /// default stream, and orders that stream's later work after it: the host does not wait (the
  /// step size planned on the device from the job's motion bounds). MPI: host data; it waits.
  /// Not while an exchange is in flight; collective over the job.
  void max_in_place(float* data, std::size_t n);
  void max_in_place(double* data, std::size_t n);

  int rank() const { return rank_; }
  int size() const { return size_; }

protected:
  /// Collective over ctx's communicator: duplicates it, so that the transport's messages never
  /// match anyone else's, and makes MPI errors return codes instead of aborting.
  explicit Transport(const MpiContext& ctx);

  /// The private communicator (errors return).
  MPI_Comm comm() const { return comm_; }
  /// Throws a kf::Error "<name> transport: <what>: <MPI error string>" unless rc is MPI_SUCCESS.
  void check_mpi(int rc, const std::string& what) const;
  /// Posts every receive, then every send, on `tag`, and waits for all (host buffers); a failure
  /// is a kf::Error beginning with `who`.
  void post_and_wait(std::span<const SendBuffer> sends, std::span<const RecvBuffer> receives,
                     int tag, const std::string& who) const;

  virtual void do_start(std::span<const SendBuffer> sends,
                        std::span<const RecvBuffer> receives) = 0;
  virtual void do_finish() = 0;
  /// max_in_place's work (host data over MPI unless a transport overrides it).
  virtual void do_max_in_place(void* data, std::size_t n, bool is_double);
  /// Called by a derived destructor: waits for an exchange in flight, never throws (the peers
  /// posted theirs at their start(), so the wait ends).
  void finish_quietly() noexcept;

private:
  void checked_max(void* data, std::size_t n, bool is_double);
  MPI_Comm comm_ = MPI_COMM_NULL;
  int rank_ = 0, size_ = 1;
  bool in_flight_ = false;
};

/// The MPI error class and text of rc ("MPI_ERR_TRUNCATE: message truncated").
std::string mpi_error_string(int rc);

/// Whether every rank of the job has a GPU of its own (no other rank of its node on the same
/// device: the rule "auto" chooses NCCL by). False in a build without CUDA. Collective over ctx's
/// communicator.
bool gpus_of_their_own(const MpiContext& ctx);

/// Builds the transport for this job. Collective over ctx's communicator.
/// `data`: where the caller's buffers live. Auto, for device data in a CUDA build: NCCL when every
/// rank of the job has a GPU of its own (NCCL refuses two ranks on one device); else CUDA IPC when
/// every rank runs on one node with a GPU (ranks sharing GPUs), unless the node refuses IPC; else
/// MPI, whose buffers are host memory (staging device data is the caller's job). Every rank makes
/// the same choice. Nccl or Ipc where it cannot work is a kf::Error saying why.
/// `stream`: the CUDA stream NCCL's or IPC's work is queued on (null: one of its own); unused by
/// MPI. Both run on the device the process already uses (knitflow selects local rank % device
/// count at start).
std::unique_ptr<Transport> make_transport(const MpiContext& ctx, TransportKind kind,
                                          MemorySpace data, CUstream_st* stream = nullptr);

} // namespace kf::comm
