#pragma once
// Sort-last image compositing's message passing, as IceT's binary swap: every rank holds a whole
// image (`pixels` records of `record_bytes` each); afterwards `root` holds the combination of all
// ranks' images, every rank having sent about one image in all whatever the rank count (half an
// image, then a quarter, ...), not whole images gathered at the root. Knows no pixels' meaning:
// the caller's `combine` folds the records it is given into its own.
//
// Two kinds of fold. A depth test (opaque layers) is the same whichever side is which. The
// "over" of translucent layers is not: it is associative but not commutative, so the images
// must be folded in the order the parts lie along every line of sight (the parts are convex
// and the order is the k-d tree's from the eye). The ordered swap takes that order and only
// ever folds runs of images adjacent in it, telling the fold which side lies in front.
#include <mpi.h>

#include <cstddef>
#include <functional>
#include <vector>

namespace kf::comm {

/// combine(mine, theirs, count): fold `count` records of `theirs` into `mine`.
using CombineRecords = std::function<void(void* mine, const void* theirs, std::size_t count)>;
/// The same for an order-dependent fold: theirs_in_front tells whether `theirs` is the image of
/// parts nearer the eye than `mine`'s.
using CombineOrdered =
    std::function<void(void* mine, const void* theirs, std::size_t count, bool theirs_in_front)>;

struct BinarySwapStats {
  std::size_t bytes_sent = 0; // by this rank, the final gather included
  int rounds = 0;             // swap rounds (log2 of the largest power of two <= ranks)
  // After the swap, this rank holds the composite of records [first, last) (empty on a rank
  // folded into another before the swap).
  std::size_t first = 0, last = 0;
  std::size_t pixels = 0; // the image's records (the gather's extent)
};

/// Collective over `comm`. `image` (pixels x record_bytes) is used as scratch on every rank; on
/// `root` it ends as the composite. Rank counts that are not powers of two first fold pairs of
/// ranks (1 into 0, 3 into 2, ...: one image each) until a power of two p remain, then swap
/// among p.
BinarySwapStats binary_swap(MPI_Comm comm, void* image, std::size_t pixels,
                            std::size_t record_bytes, const CombineRecords& combine, int root = 0);

/// The same for an order-dependent fold: `front_to_back` lists every rank of `comm` once, the
/// rank whose image lies nearest the eye first. Pairs folded before the swap and the swap's
/// groups are runs of that list, so the composite is the fold of the images in its order.
BinarySwapStats ordered_binary_swap(MPI_Comm comm, void* image, std::size_t pixels,
                                    std::size_t record_bytes, const std::vector<int>& front_to_back,
                                    const CombineOrdered& combine, int root = 0);

/// The two halves of a swap, for a caller that needs the composite's strips in between: the
/// swap alone (each rank ends holding the composite of [first, last) in place; no gather) ...
BinarySwapStats swap_strips(MPI_Comm comm, void* image, std::size_t pixels,
                            std::size_t record_bytes, const std::vector<int>& front_to_back,
                            const CombineOrdered& combine);
/// ... then the strips gathered into the root's image (bytes_sent adds this rank's strip).
void gather_strips(MPI_Comm comm, void* image, std::size_t record_bytes, BinarySwapStats& st,
                   int root = 0);

/// Every rank's strip [first, last) of `strip_records` (a record of `record_bytes` a pixel of
/// the strip, first.. in order) gathered into `whole` (pixels x record_bytes) on every rank:
/// e.g. the composite's depth, which every rank needs before drawing what blends over it.
void allgather_strips(MPI_Comm comm, const void* strip_records, std::size_t first, std::size_t last,
                      std::size_t record_bytes, void* whole, std::size_t pixels);

} // namespace kf::comm
