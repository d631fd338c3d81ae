#include "comm/BinarySwap.hpp"

#include "core/Error.hpp"

#include <algorithm>
#include <climits>
#include <numeric>
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

/// Byte counts and offsets of every rank's [first, last) (MPI's ints: a kf::Error past them).
void strip_counts(MPI_Comm comm, std::size_t first, std::size_t last, std::size_t record_bytes,
                  std::size_t pixels, std::vector<int>& counts, std::vector<int>& displs) {
  int size = 1;
  MPI_Comm_size(comm, &size);
  if (pixels * record_bytes > std::size_t(INT_MAX))
    throw Error("binary swap: an image of " + std::to_string(pixels * record_bytes) +
                " bytes is past MPI's int counts for the gather");
  std::vector<unsigned long long> ranges(2 * std::size_t(size));
  const unsigned long long mine[2] = {first, last};
  check(MPI_Allgather(mine, 2, MPI_UNSIGNED_LONG_LONG, ranges.data(), 2, MPI_UNSIGNED_LONG_LONG,
                      comm),
        "MPI_Allgather");
  counts.assign(std::size_t(size), 0);
  displs.assign(std::size_t(size), 0);
  for (std::size_t r = 0; r < std::size_t(size); ++r) {
    counts[r] = int((ranges[2 * r + 1] - ranges[2 * r]) * record_bytes);
    displs[r] = int(ranges[2 * r] * record_bytes);
  }
}

} // namespace

BinarySwapStats swap_strips(MPI_Comm comm, void* image, std::size_t pixels,
                            std::size_t record_bytes, const std::vector<int>& front_to_back,
                            const CombineOrdered& combine) {
  int rank = 0, size = 1;
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &size);
  // The order must name every rank once: a rank left out would wait forever for its partner.
  std::vector<int> seen(std::size_t(size), 0);
  for (int r : front_to_back)
    if (r < 0 || r >= size || seen[std::size_t(r)]++)
      throw Error("binary swap: the ranks' order is not a permutation of the " +
                  std::to_string(size) + " ranks");
  if (front_to_back.size() != std::size_t(size))
    throw Error("binary swap: an order of " + std::to_string(front_to_back.size()) + " ranks for " +
                std::to_string(size));
  BinarySwapStats st;
  st.last = st.pixels = pixels;
  if (size == 1)
    return st;
  auto* px = static_cast<unsigned char*>(image);
  const std::size_t image_bytes = pixels * record_bytes;
  // Places in the order: v this rank's; after the fold, the survivors' s (0 .. p - 1).
  const int v =
      int(std::find(front_to_back.begin(), front_to_back.end(), rank) - front_to_back.begin());
  int p = 1;
  while (2 * p <= size)
    p *= 2;
  const int extra = size - p;
  const auto survivor_rank = [&](int s) {
    return front_to_back[std::size_t(s < extra ? 2 * s : s + extra)];
  };
  // The fold: of the first 2 extra places, each odd one hands its whole image to the one
  // before it (which lies in front: adjacent images, so "over" stays in order).
  std::vector<unsigned char> in;
  if (v < 2 * extra && v % 2 == 1) {
    sendrecv(comm, front_to_back[std::size_t(v - 1)], px, image_bytes, nullptr, 0);
    st.bytes_sent += image_bytes;
    st.first = st.last = 0;
    return st;
  }
  if (v < 2 * extra) {
    in.resize(image_bytes);
    sendrecv(comm, front_to_back[std::size_t(v + 1)], nullptr, 0, in.data(), image_bytes);
    combine(px, in.data(), pixels, false);
  }
  const int s = v < 2 * extra ? v / 2 : v - extra;
  // The swap: each round halves the range of pixels this rank answers for; the partner's group
  // of survivors is the run next to this one's.
  std::size_t lo = 0, hi = pixels;
  for (int bit = 1; bit < p; bit *= 2, ++st.rounds) {
    const std::size_t mid = lo + (hi - lo) / 2;
    const bool upper = (s & bit) != 0;
    const std::size_t keep_lo = upper ? mid : lo, keep_hi = upper ? hi : mid;
    const std::size_t give_lo = upper ? lo : mid, give_hi = upper ? mid : hi;
    in.resize((keep_hi - keep_lo) * record_bytes);
    sendrecv(comm, survivor_rank(s ^ bit), px + give_lo * record_bytes,
             (give_hi - give_lo) * record_bytes, in.data(), in.size());
    st.bytes_sent += (give_hi - give_lo) * record_bytes;
    combine(px + keep_lo * record_bytes, in.data(), keep_hi - keep_lo, upper);
    lo = keep_lo;
    hi = keep_hi;
  }
  st.first = lo;
  st.last = hi;
  return st;
}

void gather_strips(MPI_Comm comm, void* image, std::size_t record_bytes, BinarySwapStats& st,
                   int root) {
  int rank = 0, size = 1;
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &size);
  if (size == 1)
    return;
  auto* px = static_cast<unsigned char*>(image);
  std::vector<int> counts, displs;
  strip_counts(comm, st.first, st.last, record_bytes, st.pixels, counts, displs);
  if (rank == root) {
    // The root's own strip is already in place: it gathers the others' only.
    counts[std::size_t(root)] = 0;
    check(MPI_Gatherv(MPI_IN_PLACE, 0, MPI_BYTE, px, counts.data(), displs.data(), MPI_BYTE, root,
                      comm),
          "MPI_Gatherv");
  } else {
    const std::size_t n = (st.last - st.first) * record_bytes;
    check(MPI_Gatherv(px + st.first * record_bytes, int(n), MPI_BYTE, nullptr, nullptr, nullptr,
                      MPI_BYTE, root, comm),
          "MPI_Gatherv");
    st.bytes_sent += n;
  }
}

BinarySwapStats ordered_binary_swap(MPI_Comm comm, void* image, std::size_t pixels,
                                    std::size_t record_bytes, const std::vector<int>& front_to_back,
                                    const CombineOrdered& combine, int root) {
  BinarySwapStats st = swap_strips(comm, image, pixels, record_bytes, front_to_back, combine);
  gather_strips(comm, image, record_bytes, st, root);
  return st;
}

BinarySwapStats binary_swap(MPI_Comm comm, void* image, std::size_t pixels,
                            std::size_t record_bytes, const CombineRecords& combine, int root) {
  int size = 1;
  MPI_Comm_size(comm, &size);
  std::vector<int> ranks(static_cast<std::size_t>(size));
  std::iota(ranks.begin(), ranks.end(), 0);
  return ordered_binary_swap(
      comm, image, pixels, record_bytes, ranks,
      [&](void* mine, const void* theirs, std::size_t n, bool) { combine(mine, theirs, n); }, root);
}

void allgather_strips(MPI_Comm comm, const void* strip_records, std::size_t first, std::size_t last,
                      std::size_t record_bytes, void* whole, std::size_t pixels) {
  std::vector<int> counts, displs;
  strip_counts(comm, first, last, record_bytes, pixels, counts, displs);
  check(MPI_Allgatherv(strip_records, int((last - first) * record_bytes), MPI_BYTE, whole,
                       counts.data(), displs.data(), MPI_BYTE, comm),
        "MPI_Allgatherv");
}

} // namespace kf::comm
