#pragma once
// Sort-last image compositing's message passing, as IceT's binary swap: every rank holds a whole
// image (`pixels` records of `record_bytes` each); afterwards `root` holds the combination of all
// ranks' images, every rank having sent about one image in all whatever the rank count (half an
// image, then a quarter, ...), not whole images gathered at the root. Knows no pixels' meaning:
// the caller's `combine` folds the records it is given into its own (a depth test, for opaque
// layers, is the same whichever side is which).
#include <mpi.h>

#include <cstddef>
#include <functional>

namespace kf::comm {

/// combine(mine, theirs, count): fold `count` records of `theirs` into `mine`.
using CombineRecords = std::function<void(void* mine, const void* theirs, std::size_t count)>;

struct BinarySwapStats {
  std::size_t bytes_sent = 0; // by this rank, the final gather included
  int rounds = 0;             // swap rounds (log2 of the largest power of two <= ranks)
};

/// Collective over `comm`. `image` (pixels x record_bytes) is used as scratch on every rank; on
/// `root` it ends as the composite. Rank counts that are not powers of two first fold the ranks
/// past the largest power of two p into ranks 0.. (a whole image each), then swap among p.
BinarySwapStats binary_swap(MPI_Comm comm, void* image, std::size_t pixels,
                            std::size_t record_bytes, const CombineRecords& combine, int root = 0);

} // namespace kf::comm
