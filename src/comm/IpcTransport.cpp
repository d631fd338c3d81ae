#include "comm/IpcTransport.hpp"

#include "comm/DeviceMessages.hpp"
#include "core/Error.hpp"

#include <algorithm>
#include <chrono>
#include <exception>
#include <thread>

namespace kf::comm {

namespace {

// The transport's own communicator carries nothing else but exchange_sizes (tag 0) and
// exchange_host (32767).
constexpr int kReadyTag = 1;
constexpr int kSentTag = 2;
// A mailbox holds at least this much, and a quarter over what it must when it grows: the halo's
// messages change by a few rows between rebuilds, and each growth costs a cudaMalloc, an export
// and an import.
constexpr std::size_t kLeastMailbox = 64 * 1024;

} // namespace

#define KF_IPC_CUDA(call)                                                                          \
  do {                                                                                             \
    const cudaError_t kf_e_ = (call);                                                              \
    if (kf_e_ != cudaSuccess)                                                                      \
      throw_cuda("ipc transport on rank " + std::to_string(rank()), kf_e_, #call, __FILE__,        \
                 __LINE__);                                                                        \
  } while (0)

IpcTransport::IpcTransport(const MpiContext& ctx, cudaStream_t stream)
    : Transport(ctx), stream_(stream), copied_(std::size_t(size()), nullptr),
      peer_copied_(std::size_t(size()), nullptr), sent_count_(std::size_t(size()), 0),
      received_count_(std::size_t(size()), 0) {
  // Every step that can fail on one rank is agreed on by all before the next collective, so a
  // refusal is the same kf::Error everywhere (make_transport then falls back to MPI), not a hang.
  std::string local;
  auto note = [&](cudaError_t e, const char* call) {
    if (e != cudaSuccess && local.empty()) {
      local = std::string(call) + ": " + cudaGetErrorName(e) + ": " + cudaGetErrorString(e);
      (void)cudaGetLastError();
    }
    return e == cudaSuccess;
  };
  auto agree = [&](const char* stage) {
    int ok = local.empty(), all_ok = 0;
    check_mpi(MPI_Allreduce(&ok, &all_ok, 1, MPI_INT, MPI_MIN, comm()), stage);
    if (all_ok)
      return;
    release(false);
    throw Error("ipc transport on rank " + std::to_string(rank()) + ": " +
                (local.empty() ? std::string("another rank could not ") + stage : local));
  };
  MPI_Comm node = MPI_COMM_NULL;
  check_mpi(MPI_Comm_split_type(comm(), MPI_COMM_TYPE_SHARED, rank(), MPI_INFO_NULL, &node),
            "finding the ranks of this node");
  int node_size = 0;
  MPI_Comm_size(node, &node_size);
  MPI_Comm_free(&node);
  if (node_size != size())
    local = "the job runs on more than one node (" + std::to_string(node_size) + " of its " +
            std::to_string(size()) + " ranks on this one); CUDA IPC joins the processes of one";
  if (local.empty())
    note(cudaGetDevice(&device_), "cudaGetDevice");
  // An event a peer, exported: the peer's stream waits for this rank's copies into its mailbox.
  const auto ranks = static_cast<std::size_t>(size());
  std::vector<cudaIpcEventHandle_t> mine(ranks), theirs(ranks);
  for (int r = 0; r < size() && local.empty(); ++r)
    if (r != rank() &&
        note(cudaEventCreateWithFlags(&copied_[std::size_t(r)],
                                      cudaEventInterprocess | cudaEventDisableTiming),
             "cudaEventCreateWithFlags (interprocess)"))
      note(cudaIpcGetEventHandle(&mine[std::size_t(r)], copied_[std::size_t(r)]),
           "cudaIpcGetEventHandle");
  // A probe of the memory's export: where IPC is refused it is refused here, not mid-run.
  unsigned char* probe = nullptr;
  cudaIpcMemHandle_t probe_handle{};
  if (local.empty() && note(cudaMalloc(&probe, 256), "cudaMalloc (a probe of 256 bytes)"))
    note(cudaIpcGetMemHandle(&probe_handle, probe), "cudaIpcGetMemHandle");
  agree("export its events and memory");
  const int hb = int(sizeof(cudaIpcEventHandle_t)), mb = int(sizeof(cudaIpcMemHandle_t));
  check_mpi(MPI_Alltoall(mine.data(), hb, MPI_BYTE, theirs.data(), hb, MPI_BYTE, comm()),
            "passing the interprocess events' handles");
  std::vector<cudaIpcMemHandle_t> probes(ranks);
  check_mpi(MPI_Allgather(&probe_handle, mb, MPI_BYTE, probes.data(), mb, MPI_BYTE, comm()),
            "passing the probes' handles");
  for (int r = 0; r < size() && local.empty(); ++r) {
    if (r == rank())
      continue;
    if (!note(cudaIpcOpenEventHandle(&peer_copied_[std::size_t(r)], theirs[std::size_t(r)]),
              "cudaIpcOpenEventHandle"))
      break;
    void* p = nullptr;
    if (note(cudaIpcOpenMemHandle(&p, probes[std::size_t(r)], cudaIpcMemLazyEnablePeerAccess),
             "cudaIpcOpenMemHandle"))
      note(cudaIpcCloseMemHandle(p), "cudaIpcCloseMemHandle");
  }
  if (!local.empty())
    local += " (rank " + std::to_string(rank()) + " opening its peers' handles)";
  // Every rank has closed the probes it opened once this returns: each frees its own.
  agree("open its peers' events and memory");
  note(cudaFree(probe), "cudaFree (the probe)");
  if (!stream_) {
    // The highest priority: the interior's kernels fill every SM, and the copies would otherwise
    // wait for blocks of theirs to retire.
    int least = 0, greatest = 0;
    if (note(cudaDeviceGetStreamPriorityRange(&least, &greatest),
             "cudaDeviceGetStreamPriorityRange") &&
        note(cudaStreamCreateWithPriority(&stream_, cudaStreamNonBlocking, greatest),
             "cudaStreamCreateWithPriority"))
      own_stream_ = true;
  }
  if (note(cudaEventCreateWithFlags(&filled_, cudaEventDisableTiming), "cudaEventCreate"))
    note(cudaEventCreateWithFlags(&moved_, cudaEventDisableTiming), "cudaEventCreate");
  agree("create its stream and events");
}

IpcTransport::~IpcTransport() {
  finish_quietly();
  int finalized = 0;
  MPI_Finalized(&finalized);
  // A peer's mailboxes and events may be freed only once nothing here still maps them: each
  // rank lets go of what it opened, then they meet, then each frees its own. A job failing on
  // another rank never meets: this rank's own then go with the process. Destroyed while an
  // exception unwinds (this rank failing: the job is about to be aborted) it does not wait for
  // the others at all, so the abort and its message come at once.
  bool met = false;
  if (!finalized && std::uncaught_exceptions() == 0) {
    release(false);
    MPI_Request request = MPI_REQUEST_NULL;
    if (MPI_Ibarrier(comm(), &request) == MPI_SUCCESS) {
      const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(10);
      int done = 0;
      while (!done && std::chrono::steady_clock::now() < until) {
        if (MPI_Test(&request, &done, MPI_STATUS_IGNORE) != MPI_SUCCESS)
          break;
        if (!done)
          std::this_thread::sleep_for(std::chrono::microseconds(200));
      }
      met = done != 0;
    }
  }
  release(met);
}

void IpcTransport::release(bool peers_done) noexcept {
  const auto destroy = [](cudaEvent_t& e) {
    if (e)
      (void)cudaEventDestroy(e);
    e = nullptr;
  };
  if (stream_)
    (void)cudaStreamSynchronize(stream_);
  for (auto& [key, box] : outboxes_)
    if (box.data) {
      (void)cudaIpcCloseMemHandle(box.data);
      box.data = nullptr;
    }
  for (cudaEvent_t& e : peer_copied_)
    destroy(e);
  if (!peers_done)
    return;
  for (auto& [key, box] : inboxes_) {
    for (unsigned char* p : box.retired)
      (void)cudaFree(p);
    box.retired.clear();
    if (box.data)
      (void)cudaFree(box.data);
    box.data = nullptr;
    destroy(box.drained);
  }
  for (cudaEvent_t& e : copied_)
    destroy(e);
  destroy(filled_);
  destroy(moved_);
  if (own_stream_ && stream_) {
    (void)cudaStreamDestroy(stream_);
    stream_ = nullptr;
  }
}

void IpcTransport::fail(const std::string& what) const {
  throw Error("ipc transport on rank " + std::to_string(rank()) + ": " + what);
}

IpcTransport::Mailbox& IpcTransport::inbox(int peer, std::size_t bytes, ReadyNote& note) {
  Mailbox& box = inboxes_[{peer, int(received_count_[std::size_t(peer)] & 1)}];
  if (!box.drained)
    KF_IPC_CUDA(cudaEventCreateWithFlags(&box.drained, cudaEventDisableTiming));
  // The last copy out of this mailbox (two exchanges back: the other one took the last) must be
  // done before the peer may write it again. Never recorded: returns at once.
  KF_IPC_CUDA(cudaEventSynchronize(box.drained));
  note = ReadyNote{box.capacity, 0, {}};
  if (bytes <= box.capacity)
    return box;
  // Outgrown: the old one stays until the peer has closed it (its next note says so).
  if (box.data)
    box.retired.push_back(box.data);
  box.data = nullptr;
  box.capacity = 0;
  const std::size_t capacity = std::max(kLeastMailbox, bytes + bytes / 4);
  void* p = nullptr;
  KF_IPC_CUDA(cudaMalloc(&p, capacity));
  box.data = static_cast<unsigned char*>(p);
  box.capacity = capacity;
  KF_IPC_CUDA(cudaIpcGetMemHandle(&box.handle, p));
  note = ReadyNote{capacity, 1, box.handle};
  return box;
}

void IpcTransport::do_start(std::span<const SendBuffer> sends,
                            std::span<const RecvBuffer> receives) {
  const std::string who = "ipc transport on rank " + std::to_string(rank());
  require_device_buffers(who, sends, receives);
  send_groups_.clear();
  recv_groups_.clear();
  auto group_of = [](std::vector<Group>& groups, int peer) -> Group& {
    for (Group& g : groups)
      if (g.peer == peer)
        return g;
    groups.push_back(Group{peer, 0, {}, {}, false});
    return groups.back();
  };
  for (const SendBuffer& s : sends)
    if (s.peer != rank()) {
      Group& g = group_of(send_groups_, s.peer);
      g.sends.push_back(s);
      g.total += s.bytes;
    }
  for (const RecvBuffer& r : receives)
    if (r.peer != rank()) {
      Group& g = group_of(recv_groups_, r.peer);
      g.receives.push_back(r);
      g.total += r.bytes;
    }
  // The send buffers are filled by kernels on the legacy default stream (and the receive buffers
  // read by the last exchange's unpacking there): the copies wait for them on the device.
  KF_IPC_CUDA(cudaEventRecord(filled_, cudaStreamLegacy));
  KF_IPC_CUDA(cudaStreamWaitEvent(stream_, filled_, 0));
  copy_to_self(who, rank(), sends, receives, stream_);

  const std::size_t ns = send_groups_.size(), nr = recv_groups_.size();
  ready_out_.assign(nr, {});
  sent_in_.assign(nr, 0);
  ready_in_.assign(ns, {});
  sent_out_.assign(ns, 0);
  ready_out_req_.assign(nr, MPI_REQUEST_NULL);
  sent_in_req_.assign(nr, MPI_REQUEST_NULL);
  ready_in_req_.assign(ns, MPI_REQUEST_NULL);
  sent_out_req_.assign(ns, MPI_REQUEST_NULL);
  const int note_bytes = int(sizeof(ReadyNote));
  // As a receiver: each sender is told that its mailbox here is free (and where it is now).
  for (std::size_t i = 0; i < nr; ++i) {
    const Group& g = recv_groups_[i];
    inbox(g.peer, g.total, ready_out_[i]);
    check_mpi(MPI_Irecv(&sent_in_[i], 1, MPI_UINT64_T, g.peer, kSentTag, comm(), &sent_in_req_[i]),
              "posting the note of rank " + std::to_string(g.peer) + "'s copies");
    check_mpi(MPI_Isend(&ready_out_[i], note_bytes, MPI_BYTE, g.peer, kReadyTag, comm(),
                        &ready_out_req_[i]),
              "telling rank " + std::to_string(g.peer) + " its mailbox is free");
  }
  // As a sender: the copies go now into each mailbox already free, the rest at finish().
  for (std::size_t i = 0; i < ns; ++i)
    check_mpi(MPI_Irecv(&ready_in_[i], note_bytes, MPI_BYTE, send_groups_[i].peer, kReadyTag,
                        comm(), &ready_in_req_[i]),
              "posting rank " + std::to_string(send_groups_[i].peer) + "'s mailbox note");
  for (std::size_t i = 0; i < ns; ++i) {
    int here = 0;
    check_mpi(MPI_Test(&ready_in_req_[i], &here, MPI_STATUS_IGNORE), "testing a mailbox note");
    if (here)
      copy_out(i);
  }
}

void IpcTransport::copy_out(std::size_t i) {
  Group& g = send_groups_[i];
  const ReadyNote& note = ready_in_[i];
  Mailbox& out = outboxes_[{g.peer, int(sent_count_[std::size_t(g.peer)] & 1)}];
  if (note.fresh) {
    // The peer made this mailbox anew (it outgrew the last): the old mapping goes first, since
    // the peer frees it once this rank's next note comes.
    if (out.data)
      KF_IPC_CUDA(cudaIpcCloseMemHandle(out.data));
    out.data = nullptr;
    void* p = nullptr;
    KF_IPC_CUDA(cudaIpcOpenMemHandle(&p, note.handle, cudaIpcMemLazyEnablePeerAccess));
    out.data = static_cast<unsigned char*>(p);
    out.capacity = note.capacity;
  }
  if (g.total > out.capacity || (g.total > 0 && !out.data))
    fail("sends " + std::to_string(g.total) + " bytes to rank " + std::to_string(g.peer) +
         ", which expects at most " + std::to_string(out.capacity) +
         " (sender and receiver disagree on the size; exchange_sizes tells the receiver)");
  std::size_t offset = 0;
  for (const SendBuffer& s : g.sends) {
    if (s.bytes > 0)
      KF_IPC_CUDA(
          cudaMemcpyAsync(out.data + offset, s.data, s.bytes, cudaMemcpyDeviceToDevice, stream_));
    offset += s.bytes;
  }
  KF_IPC_CUDA(cudaEventRecord(copied_[std::size_t(g.peer)], stream_));
  sent_out_[i] = g.total;
  check_mpi(MPI_Isend(&sent_out_[i], 1, MPI_UINT64_T, g.peer, kSentTag, comm(), &sent_out_req_[i]),
            "telling rank " + std::to_string(g.peer) + " its message is queued");
  g.copied = true;
}

void IpcTransport::do_finish() {
  for (std::size_t i = 0; i < send_groups_.size(); ++i)
    if (!send_groups_[i].copied) {
      check_mpi(MPI_Wait(&ready_in_req_[i], MPI_STATUS_IGNORE),
                "waiting for rank " + std::to_string(send_groups_[i].peer) + "'s mailbox note");
      copy_out(i);
    }
  // A size the sender disagrees with is reported after every message is through, so that both
  // sides count this exchange and the transport stays usable.
  std::string mismatch;
  for (std::size_t i = 0; i < recv_groups_.size(); ++i) {
    const Group& g = recv_groups_[i];
    check_mpi(MPI_Wait(&sent_in_req_[i], MPI_STATUS_IGNORE),
              "waiting for rank " + std::to_string(g.peer) + "'s copies");
    Mailbox& box = inboxes_[{g.peer, int(received_count_[std::size_t(g.peer)] & 1)}];
    // On the device, not the host: the peer's copies into the mailbox, then out of it.
    KF_IPC_CUDA(cudaStreamWaitEvent(stream_, peer_copied_[std::size_t(g.peer)], 0));
    if (sent_in_[i] != g.total && mismatch.empty())
      mismatch = "receive from rank " + std::to_string(g.peer) + ": it sent " +
                 std::to_string(sent_in_[i]) + " bytes, expected " + std::to_string(g.total) +
                 " (sender and receiver disagree on the size; exchange_sizes tells the receiver)";
    std::size_t offset = 0;
    for (const RecvBuffer& r : g.receives) {
      if (r.bytes > 0 && sent_in_[i] == g.total)
        KF_IPC_CUDA(
            cudaMemcpyAsync(r.data, box.data + offset, r.bytes, cudaMemcpyDeviceToDevice, stream_));
      offset += r.bytes;
    }
    KF_IPC_CUDA(cudaEventRecord(box.drained, stream_));
    // The peer opened this mailbox, closing the one it outgrew, before it sent its note.
    for (unsigned char* p : box.retired)
      KF_IPC_CUDA(cudaFree(p));
    box.retired.clear();
    ++received_count_[std::size_t(g.peer)];
  }
  for (const Group& g : send_groups_)
    ++sent_count_[std::size_t(g.peer)];
  // The unpacking kernels and everything after them on the legacy default stream wait for the
  // messages on the device.
  KF_IPC_CUDA(cudaEventRecord(moved_, stream_));
  KF_IPC_CUDA(cudaStreamWaitEvent(cudaStreamLegacy, moved_, 0));
  // The notes are a few bytes each: sent by now, or at once.
  check_mpi(MPI_Waitall(int(ready_out_req_.size()), ready_out_req_.data(), MPI_STATUSES_IGNORE),
            "sending the mailbox notes");
  check_mpi(MPI_Waitall(int(sent_out_req_.size()), sent_out_req_.data(), MPI_STATUSES_IGNORE),
            "sending the notes of the copies");
  if (!mismatch.empty())
    fail(mismatch);
}

void IpcTransport::do_max_in_place(void* data, std::size_t n, bool is_double) {
  if (n == 0)
    return;
  const std::size_t bytes = n * (is_double ? sizeof(double) : sizeof(float));
  std::vector<unsigned char> host(bytes);
  // On the legacy default stream: after the work that wrote the values, before the work that
  // reads them.
  KF_IPC_CUDA(cudaMemcpy(host.data(), data, bytes, cudaMemcpyDeviceToHost));
  Transport::do_max_in_place(host.data(), n, is_double);
  KF_IPC_CUDA(cudaMemcpy(data, host.data(), bytes, cudaMemcpyHostToDevice));
}

} // namespace kf::comm
