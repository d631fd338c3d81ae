#include "comm/MpiTransport.hpp"

#include "core/Error.hpp"

#include <algorithm>

namespace kf::comm {

namespace {
const char* const kSizesDisagree =
    " (sender and receiver disagree on the size; exchange_sizes tells the receiver)";
} // namespace

MpiTransport::MpiTransport(const MpiContext& ctx, std::size_t max_message_bytes)
    : Transport(ctx), max_message_(std::clamp<std::size_t>(max_message_bytes, 1, 1u << 30)),
      ordinal_(std::size_t(ctx.size()), 0) {
  void* value = nullptr;
  int found = 0;
  check_mpi(MPI_Comm_get_attr(comm(), MPI_TAG_UB, &value, &found), "reading MPI_TAG_UB");
  if (found)
    tag_ub_ = *static_cast<int*>(value);
}

MpiTransport::~MpiTransport() {
  finish_quietly();
}

void MpiTransport::abandon() noexcept {
  // Nothing may write into the caller's buffers once the error is thrown: a pending receive is
  // cancelled and waited for (that wait ends at once, matched or not). A pending send is
  // released to finish on its own; waiting could hang on a peer that failed too.
  for (std::size_t i = 0; i < requests_.size(); ++i) {
    if (requests_[i] == MPI_REQUEST_NULL)
      continue;
    if (pieces_[i].receive) {
      MPI_Cancel(&requests_[i]);
      MPI_Wait(&requests_[i], MPI_STATUS_IGNORE);
    } else {
      MPI_Request_free(&requests_[i]);
    }
  }
  requests_.clear();
  pieces_.clear();
}

void MpiTransport::do_start(std::span<const SendBuffer> sends,
                            std::span<const RecvBuffer> receives) {
  requests_.clear();
  pieces_.clear();
  // The k-th message between two ranks in one exchange has tag k + 1 (tag 0 carries sizes), so
  // several buffers for one peer never swap. Pieces of a split buffer share its tag: MPI keeps
  // messages of one (source, tag, communicator) in the order they were posted.
  auto post = [&](bool receive, int peer, char* data, std::size_t bytes) {
    const int tag = 1 + ordinal_[std::size_t(peer)]++;
    const char* dir = receive ? "receive from" : "send to";
    if (tag > tag_ub_) {
      abandon();
      throw Error("mpi transport on rank " + std::to_string(rank()) + ": more than " +
                  std::to_string(tag_ub_ - 1) + " messages to one peer in one exchange (" + dir +
                  " rank " + std::to_string(peer) + "); MPI_TAG_UB is " + std::to_string(tag_ub_));
    }
    std::size_t offset = 0;
    do { // a zero-byte buffer is still one (empty) message, so both sides' counts agree
      const std::size_t n = std::min(max_message_, bytes - offset);
      MPI_Request request;
      const int rc = receive
                         ? MPI_Irecv(data + offset, int(n), MPI_BYTE, peer, tag, comm(), &request)
                         : MPI_Isend(data + offset, int(n), MPI_BYTE, peer, tag, comm(), &request);
      if (rc != MPI_SUCCESS) {
        abandon();
        check_mpi(rc, std::string("posting ") + dir + " rank " + std::to_string(peer) + " (tag " +
                          std::to_string(tag) + ", " + std::to_string(n) + " bytes)");
      }
      requests_.push_back(request);
      pieces_.push_back({peer, tag, n, receive});
      offset += n;
    } while (offset < bytes);
  };
  // Receives and sends count their tags separately (my k-th send to p is p's k-th receive from
  // me). Only the ranks touched are reset: O(peers), not O(ranks), per exchange.
  auto reset = [&] {
    for (const RecvBuffer& r : receives)
      ordinal_[std::size_t(r.peer)] = 0;
    for (const SendBuffer& s : sends)
      ordinal_[std::size_t(s.peer)] = 0;
  };
  try {
    // Receives first: a message that finds its receive already posted needs no unexpected-
    // message buffering.
    for (const RecvBuffer& r : receives)
      post(true, r.peer, static_cast<char*>(r.data), r.bytes);
    reset();
    for (const SendBuffer& s : sends) // MPI only reads a send buffer; the cast serves the lambda
      post(false, s.peer, const_cast<char*>(static_cast<const char*>(s.data)), s.bytes);
  } catch (...) {
    reset();
    throw;
  }
  reset();
}

void MpiTransport::do_finish() {
  statuses_.resize(requests_.size());
  const int rc = MPI_Waitall(int(requests_.size()), requests_.data(), statuses_.data());
  auto where = [&](std::size_t i) {
    const Piece& p = pieces_[i];
    return std::string(p.receive ? "receive from" : "send to") + " rank " + std::to_string(p.peer) +
           " (tag " + std::to_string(p.tag) + ", " + std::to_string(p.bytes) + " bytes)";
  };
  std::string error;
  if (rc == MPI_ERR_IN_STATUS) {
    for (std::size_t i = 0; i < statuses_.size() && error.empty(); ++i) {
      const int e = statuses_[i].MPI_ERROR;
      if (e != MPI_SUCCESS && e != MPI_ERR_PENDING) {
        error = where(i) + ": " + mpi_error_string(e);
        int cls = e;
        MPI_Error_class(e, &cls);
        if (cls == MPI_ERR_TRUNCATE)
          error += kSizesDisagree;
      }
    }
    if (error.empty())
      error = "waiting: " + mpi_error_string(rc);
  } else if (rc != MPI_SUCCESS) {
    error = "waiting: " + mpi_error_string(rc);
  } else {
    // A shorter message than the receive expects is legal MPI; here it means the two sides
    // disagree on the size, so it is an error too.
    for (std::size_t i = 0; i < statuses_.size() && error.empty(); ++i) {
      if (!pieces_[i].receive)
        continue;
      int count = 0;
      MPI_Get_count(&statuses_[i], MPI_BYTE, &count);
      if (std::size_t(count) != pieces_[i].bytes)
        error = where(i) + ": " + std::to_string(count) + " bytes arrived" + kSizesDisagree;
    }
  }
  if (rc != MPI_SUCCESS)
    abandon(); // the requests MPI left pending (MPI_ERR_PENDING)
  requests_.clear();
  pieces_.clear();
  if (!error.empty())
    throw Error("mpi transport on rank " + std::to_string(rank()) + ": " + error);
}

} // namespace kf::comm
