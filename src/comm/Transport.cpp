#include "comm/Transport.hpp"

#include "comm/MpiTransport.hpp"
#include "core/Error.hpp"

#include <algorithm>
#include <array>
#include <cstring>

#if defined(KF_WITH_CUDA)
#include "comm/IpcTransport.hpp"
#include "comm/NcclTransport.hpp"

#include <cuda_runtime.h>
#endif

namespace kf::comm {

namespace {

// Sizes go on their own tag so that exchange_sizes never matches data of an exchange in flight
// (MpiTransport's data tags start at 1).
constexpr int kSizesTag = 0;
// exchange_host's messages: a tag every MPI has (MPI_TAG_UB >= 32767) and above the data tags one
// exchange uses (one a buffer to a peer).
constexpr int kHostTag = 32767;

} // namespace

std::string mpi_error_string(int rc) {
  char text[MPI_MAX_ERROR_STRING];
  int len = 0;
  if (MPI_Error_string(rc, text, &len) != MPI_SUCCESS)
    return "MPI error " + std::to_string(rc);
  int cls = rc;
  MPI_Error_class(rc, &cls);
  char cls_text[MPI_MAX_ERROR_STRING];
  int cls_len = 0;
  MPI_Error_string(cls, cls_text, &cls_len);
  std::string out(text, std::size_t(len));
  // The class's text names the kind ("MPI_ERR_TRUNCATE: message truncated" in Open MPI); keep it
  // when it adds something.
  if (cls != rc && cls_len > 0)
    out = std::string(cls_text, std::size_t(cls_len)) + " (" + out + ")";
  return out;
}

std::string_view to_string(MemorySpace s) {
  return s == MemorySpace::Host ? "host" : "device";
}

std::string_view to_string(TransportKind k) {
  switch (k) {
  case TransportKind::Auto:
    return "auto";
  case TransportKind::Mpi:
    return "mpi";
  case TransportKind::Nccl:
    return "nccl";
  case TransportKind::Ipc:
    return "ipc";
  }
  return "?";
}

TransportKind parse_transport_kind(std::string_view text) {
  for (TransportKind k :
       {TransportKind::Auto, TransportKind::Mpi, TransportKind::Nccl, TransportKind::Ipc})
    if (text == to_string(k))
      return k;
  throw Error("unknown transport '" + std::string(text) + "': expected auto, mpi, nccl or ipc");
}

// ---- Transport ----------------------------------------------------------------------------------

Transport::Transport(const MpiContext& ctx) : rank_(ctx.rank()), size_(ctx.size()) {
  int rc = MPI_Comm_dup(ctx.comm(), &comm_);
  if (rc != MPI_SUCCESS)
    throw Error("transport: duplicating the communicator failed: " + mpi_error_string(rc));
  rc = MPI_Comm_set_errhandler(comm_, MPI_ERRORS_RETURN);
  if (rc != MPI_SUCCESS)
    throw Error("transport: setting MPI_ERRORS_RETURN failed: " + mpi_error_string(rc));
}

Transport::~Transport() {
  // A transport destroyed after MPI_Finalize (a static, say) has nothing left to free.
  int finalized = 0;
  MPI_Finalized(&finalized);
  if (!finalized && comm_ != MPI_COMM_NULL)
    MPI_Comm_free(&comm_);
}

void Transport::check_mpi(int rc, const std::string& what) const {
  if (rc != MPI_SUCCESS)
    throw Error(std::string(name()) + " transport: " + what + ": " + mpi_error_string(rc));
}

void Transport::start(std::span<const SendBuffer> sends, std::span<const RecvBuffer> receives) {
  const std::string who = std::string(name()) + " transport on rank " + std::to_string(rank_);
  if (in_flight_)
    throw Error(who + ": start() while an exchange is in flight; call finish() first");
  // Checked here, before anything is posted, so a bad list leaves nothing half-sent.
  auto check = [&](const char* what, std::size_t i, int peer, const void* data, std::size_t bytes) {
    if (peer < 0 || peer >= size_)
      throw Error(who + ": " + what + " " + std::to_string(i) + " names rank " +
                  std::to_string(peer) + ", but the job has ranks 0.." + std::to_string(size_ - 1));
    if (data == nullptr && bytes > 0)
      throw Error(who + ": " + what + " " + std::to_string(i) + " (rank " + std::to_string(peer) +
                  ") has no buffer for " + std::to_string(bytes) + " bytes");
  };
  for (std::size_t i = 0; i < sends.size(); ++i)
    check("send", i, sends[i].peer, sends[i].data, sends[i].bytes);
  for (std::size_t i = 0; i < receives.size(); ++i)
    check("receive", i, receives[i].peer, receives[i].data, receives[i].bytes);
  do_start(sends, receives);
  in_flight_ = true;
}

void Transport::max_in_place(float* data, std::size_t n) {
  checked_max(data, n, false);
}

void Transport::max_in_place(double* data, std::size_t n) {
  checked_max(data, n, true);
}

void Transport::checked_max(void* data, std::size_t n, bool is_double) {
  if (in_flight_)
    throw Error(std::string(name()) + " transport on rank " + std::to_string(rank_) +
                ": max_in_place() while an exchange is in flight");
  do_max_in_place(data, n, is_double);
}

void Transport::do_max_in_place(void* data, std::size_t n, bool is_double) {
  check_mpi(
      MPI_Allreduce(MPI_IN_PLACE, data, int(n), is_double ? MPI_DOUBLE : MPI_FLOAT, MPI_MAX, comm_),
      "the all-reduce of maxima");
}

void Transport::finish() {
  if (!in_flight_)
    return;
  // Idle again whatever happens: a failed exchange is over, not retried.
  in_flight_ = false;
  do_finish();
}

void Transport::finish_quietly() noexcept {
  if (!in_flight_)
    return;
  in_flight_ = false;
  try {
    do_finish();
  } catch (...) {
  }
}

std::vector<std::uint64_t>
Transport::exchange_sizes(std::span<const int> peers,
                          std::span<const std::uint64_t> send_bytes) const {
  const std::string who = "exchange_sizes on rank " + std::to_string(rank_);
  if (peers.size() != send_bytes.size())
    throw Error(who + ": " + std::to_string(peers.size()) + " peers but " +
                std::to_string(send_bytes.size()) + " sizes");
  std::vector<int> sorted(peers.begin(), peers.end());
  std::sort(sorted.begin(), sorted.end());
  for (std::size_t i = 0; i < sorted.size(); ++i) {
    if (sorted[i] < 0 || sorted[i] >= size_)
      throw Error(who + ": peer " + std::to_string(sorted[i]) + " is not a rank (0.." +
                  std::to_string(size_ - 1) + ")");
    // A repeated peer would make two sizes share one (source, tag): which one lands where would
    // be up to the order of posting, so it is refused.
    if (i > 0 && sorted[i] == sorted[i - 1])
      throw Error(who + ": peer " + std::to_string(sorted[i]) + " is listed twice");
  }
  std::vector<std::uint64_t> recv(peers.size(), 0);
  std::vector<SendBuffer> sends(peers.size());
  std::vector<RecvBuffer> receives(peers.size());
  for (std::size_t i = 0; i < peers.size(); ++i) {
    sends[i] = {peers[i], &send_bytes[i], sizeof(std::uint64_t)};
    receives[i] = {peers[i], &recv[i], sizeof(std::uint64_t)};
  }
  post_and_wait(sends, receives, kSizesTag, who);
  return recv;
}

void Transport::exchange_host(std::span<const SendBuffer> sends,
                              std::span<const RecvBuffer> receives) const {
  const std::string who = "exchange_host on rank " + std::to_string(rank_);
  if (in_flight_)
    throw Error(who + ": an exchange is in flight");
  post_and_wait(sends, receives, kHostTag, who);
}

void Transport::post_and_wait(std::span<const SendBuffer> sends,
                              std::span<const RecvBuffer> receives, int tag,
                              const std::string& who) const {
  std::vector<MPI_Request> requests(receives.size() + sends.size(), MPI_REQUEST_NULL);
  std::size_t posted = 0;
  auto fail = [&](const std::string& what, int rc) {
    MPI_Waitall(int(posted), requests.data(), MPI_STATUSES_IGNORE);
    throw Error(who + ": " + what + ": " + mpi_error_string(rc));
  };
  for (const RecvBuffer& r : receives) {
    const int rc = MPI_Irecv(r.data, int(r.bytes), MPI_BYTE, r.peer, tag, comm_, &requests[posted]);
    if (rc != MPI_SUCCESS)
      fail("receiving " + std::to_string(r.bytes) + " bytes from rank " + std::to_string(r.peer),
           rc);
    ++posted;
  }
  for (const SendBuffer& sb : sends) {
    const int rc =
        MPI_Isend(sb.data, int(sb.bytes), MPI_BYTE, sb.peer, tag, comm_, &requests[posted]);
    if (rc != MPI_SUCCESS)
      fail("sending " + std::to_string(sb.bytes) + " bytes to rank " + std::to_string(sb.peer), rc);
    ++posted;
  }
  const int rc = MPI_Waitall(int(requests.size()), requests.data(), MPI_STATUSES_IGNORE);
  if (rc != MPI_SUCCESS)
    throw Error(who + ": waiting: " + mpi_error_string(rc));
}

// ---- factory ------------------------------------------------------------------------------------

namespace {

/// What this job's GPUs allow, the same on every rank: why NCCL cannot carry its device buffers
/// ("" if it can), why CUDA IPC cannot ("" if it may: the node has the last word, at the
/// transport's start), and the GPU this rank uses. Collective over ctx.
struct DeviceLayout {
  std::string no_nccl, no_ipc;
  int device = -1;
};

DeviceLayout device_layout(const MpiContext& ctx) {
  DeviceLayout layout;
#if defined(KF_WITH_CUDA)
  // No early return before the collectives below: every rank must reach them.
  int count = 0;
  if (cudaGetDeviceCount(&count) != cudaSuccess) {
    (void)cudaGetLastError(); // no driver or no GPU: "no device", not an error
    count = 0;
  }
  // The PCI bus id names the physical GPU whatever CUDA_VISIBLE_DEVICES renumbers, and is what
  // NCCL itself compares when it refuses two ranks on one device. Where every rank sees every
  // device this is the same as "node-local ranks <= device count".
  std::array<char, 32> bus{};
  // The device this process already uses (knitflow and the tests choose local rank % count):
  // the transport must not move the process to another one under its buffers.
  int& device = layout.device;
  if (count > 0 && cudaGetDevice(&device) != cudaSuccess) {
    (void)cudaGetLastError();
    count = 0;
  }
  if (count > 0) {
    if (cudaDeviceGetPCIBusId(bus.data(), int(bus.size()), device) != cudaSuccess) {
      (void)cudaGetLastError();
      bus.fill(0);
      count = 0;
    }
  }
  MPI_Comm local;
  MPI_Comm_split_type(ctx.comm(), MPI_COMM_TYPE_SHARED, ctx.rank(), MPI_INFO_NULL, &local);
  int local_size = 1;
  MPI_Comm_size(local, &local_size);
  std::vector<char> all(bus.size() * std::size_t(local_size));
  MPI_Allgather(bus.data(), int(bus.size()), MPI_CHAR, all.data(), int(bus.size()), MPI_CHAR,
                local);
  MPI_Comm_free(&local);
  int sharing = 0;
  for (int r = 0; r < local_size; ++r)
    sharing += std::memcmp(all.data() + bus.size() * std::size_t(r), bus.data(), bus.size()) == 0;
  // [ranks without a GPU of their own, ranks without a GPU, ranks whose node lacks some]
  std::array<int, 3> bad{count == 0 || sharing > 1, count == 0, local_size != ctx.size()}, sums{};
  MPI_Allreduce(bad.data(), sums.data(), 3, MPI_INT, MPI_SUM, ctx.comm());
  if (sums[0] > 0) {
    layout.no_nccl = std::to_string(sums[0]) + " of " + std::to_string(ctx.size()) +
                     " ranks have no GPU of their own (NCCL refuses two ranks on one device)";
    if (bad[0])
      layout.no_nccl += "; rank " + std::to_string(ctx.rank()) + " sees " + std::to_string(count) +
                        " device(s) for " + std::to_string(local_size) + " rank(s) on its node";
  }
  if (sums[1] > 0)
    layout.no_ipc =
        std::to_string(sums[1]) + " of " + std::to_string(ctx.size()) + " ranks see no GPU";
  else if (sums[2] > 0)
    layout.no_ipc = "the job's ranks run on more than one node (CUDA IPC joins the processes "
                    "of one)";
#else
  (void)ctx;
  layout.no_nccl = layout.no_ipc = "this build has no CUDA (configure with -DKF_ENABLE_CUDA=ON)";
#endif
  return layout;
}

} // namespace

bool gpus_of_their_own(const MpiContext& ctx) {
  return device_layout(ctx).no_nccl.empty();
}

std::unique_ptr<Transport> make_transport(const MpiContext& ctx, TransportKind kind,
                                          MemorySpace data, [[maybe_unused]] CUstream_st* stream) {
  if (kind == TransportKind::Mpi)
    return std::make_unique<MpiTransport>(ctx);
  // `data` and `kind` are the same on every rank (the job's settings), so every rank either
  // enters the collective checks or skips them.
  if (data == MemorySpace::Host) {
    if (kind != TransportKind::Auto)
      throw Error("transport " + std::string(to_string(kind)) +
                  " cannot run here: the data lives in host memory and it moves device buffers; "
                  "choose auto or mpi");
    return std::make_unique<MpiTransport>(ctx);
  }
  const DeviceLayout layout = device_layout(ctx);
#if defined(KF_WITH_CUDA)
  if (layout.no_nccl.empty() && kind != TransportKind::Ipc)
    return std::make_unique<NcclTransport>(ctx, layout.device, stream);
  if (layout.no_ipc.empty() && kind != TransportKind::Nccl) {
    try {
      return std::make_unique<IpcTransport>(ctx, stream);
    } catch (const Error&) { // the node refused (every rank alike): MPI then, unless asked for
      if (kind == TransportKind::Ipc)
        throw;
    }
  }
#endif
  if (kind == TransportKind::Nccl)
    throw Error("transport nccl cannot run here: " + layout.no_nccl + "; choose auto or mpi");
  if (kind == TransportKind::Ipc)
    throw Error("transport ipc cannot run here: " + layout.no_ipc + "; choose auto or mpi");
  return std::make_unique<MpiTransport>(ctx);
}

} // namespace kf::comm
