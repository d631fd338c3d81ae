#include "comm/BinarySwap.hpp"

#include "core/Error.hpp"

#include <climits>
#include <string>
#include <vector>

namespace kf::comm {

namespace {

void check(int rc, const char* what) {
  if (rc != MPI_SUCCESS)
    throw Error(std::string("binary swap: ") + what + " failed (MPI error " + std::to_string(rc) +
                ")");
}

/// Messages in pieces of at most INT_MAX bytes (MPI's counts are ints).
void sendrecv(MPI_Comm comm, int peer, const unsigned char* out, std::size_t out_bytes,
              unsigned char* in, std::size_t in_bytes) {
  const std::size_t piece = INT_MAX;
  for (std::size_t done_out = 0, done_in = 0; done_out < out_bytes || done_in < in_bytes;) {
    const int o = int(std::min(piece, out_bytes - done_out));
    const int i = int(std::min(piece, in_bytes - done_in));
    check(MPI_Sendrecv(out + done_out, o, MPI_BYTE, peer, 71, in + done_in, i, MPI_BYTE, peer, 71,
                       comm, MPI_STATUS_IGNORE),
          "MPI_Sendrecv");
    done_out += std::size_t(o);
    done_in += std::size_t(i);
  }
}

} // namespace

BinarySwapStats binary_swap(MPI_Comm comm, void* image, std::size_t pixels,
                            std::size_t record_bytes, const CombineRecords& combine, int root) {
  int rank = 0, size = 1;
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &size);
  BinarySwapStats st;
  auto* px = static_cast<unsigned char*>(image);
  const std::size_t image_bytes = pixels * record_bytes;
  if (size == 1)
    return st;
  int p = 1;
  while (2 * p <= size)
    p *= 2;
  // The fold: ranks p.. hand their whole image to rank - p.
  std::vector<unsigned char> in;
  if (rank >= p) {
    sendrecv(comm, rank - p, px, image_bytes, nullptr, 0);
    st.bytes_sent += image_bytes;
  } else if (rank + p < size) {
    in.resize(image_bytes);
    sendrecv(comm, rank + p, nullptr, 0, in.data(), image_bytes);
    combine(px, in.data(), pixels);
  }
  // The swap: each round halves the range of pixels this rank answers for.
  std::size_t lo = 0, hi = pixels;
  if (rank < p)
    for (int bit = 1; bit < p; bit *= 2, ++st.rounds) {
      const std::size_t mid = lo + (hi - lo) / 2;
      const bool upper = (rank & bit) != 0;
      const std::size_t keep_lo = upper ? mid : lo, keep_hi = upper ? hi : mid;
      const std::size_t give_lo = upper ? lo : mid, give_hi = upper ? mid : hi;
      in.resize((keep_hi - keep_lo) * record_bytes);
      sendrecv(comm, rank ^ bit, px + give_lo * record_bytes, (give_hi - give_lo) * record_bytes,
               in.data(), in.size());
      st.bytes_sent += (give_hi - give_lo) * record_bytes;
      combine(px + keep_lo * record_bytes, in.data(), keep_hi - keep_lo);
      lo = keep_lo;
      hi = keep_hi;
    }
  else
    lo = hi = 0;
  // The gather: each of the p ranks' final ranges to the root, in place.
  std::vector<unsigned long long> ranges(2 * std::size_t(size));
  const unsigned long long mine[2] = {lo, hi};
  check(MPI_Gather(mine, 2, MPI_UNSIGNED_LONG_LONG, ranges.data(), 2, MPI_UNSIGNED_LONG_LONG, root,
                   comm),
        "MPI_Gather");
  if (image_bytes > std::size_t(INT_MAX))
    throw Error("binary swap: an image of " + std::to_string(image_bytes) +
                " bytes is past MPI's int counts for the gather");
  if (rank == root) {
    std::vector<int> counts(static_cast<std::size_t>(size)), displs(counts.size());
    for (int r = 0; r < size; ++r) {
      counts[std::size_t(r)] = int((ranges[2 * r + 1] - ranges[2 * r]) * record_bytes);
      displs[std::size_t(r)] = int(ranges[2 * r] * record_bytes);
    }
    // The root's own range is already in place: it gathers the others' only.
    counts[std::size_t(root)] = 0;
    check(MPI_Gatherv(MPI_IN_PLACE, 0, MPI_BYTE, px, counts.data(), displs.data(), MPI_BYTE, root,
                      comm),
          "MPI_Gatherv");
  } else {
    const std::size_t n = (hi - lo) * record_bytes;
    check(MPI_Gatherv(px + lo * record_bytes, int(n), MPI_BYTE, nullptr, nullptr, nullptr, MPI_BYTE,
                      root, comm),
          "MPI_Gatherv");
    st.bytes_sent += n;
  }
  return st;
}

} // namespace kf::comm
