#pragma once
// Appending a particle's neighbours to its list row through a small ring, for builders whose
// lanes find neighbours at different rates (SphChunkListBuilder).
#include "core/Math.hpp"
#include "kernels/grid/NeighbourList.hpp"

namespace kf {

/// Slots in a StagedRowAppender's ring: up to kStageSlots - kListGroup + 1 = 25 pushes between
/// two flushes.
constexpr std::uint32_t kStageSlots = 32;

/// Appends one particle's neighbours to its row (as RowAppender: counts all, writes those that
/// fit), staged in a ring of kStageSlots slots and written a whole group of eight at a time by
/// flush(). A push is one store into the ring, with no branch; the 32-byte group stores, which
/// only some lanes of a warp make at any moment, wait for flush(). Why: ncu's source view of the
/// chunk builder with RowAppender (entries held in registers, a store branch in every push) put
/// half of its instructions in the pushes, ~36 a push with 10 of 32 lanes active.
/// Stride is the distance between a lane's slots: 32 with the ring in shared memory, slot s of
/// lane l at ring[32 s + l], so the lanes of a warp push into 32 different banks; 1 for a ring of
/// one lane (the CPU).
template <std::uint32_t Stride>
class StagedRowAppender {
public:
  KF_HD KF_INLINE StagedRowAppender(const ListSink& out, std::size_t i, std::uint32_t* ring)
      : out_(out), i_(i), ring_(ring) {}

  /// Appends base + k for each bit k set in `bits`, in increasing k; at most 16 bits set (so a
  /// flush() after each call keeps the ring from wrapping onto unwritten slots).
  KF_HD KF_INLINE void push_bits(std::uint32_t base, std::uint32_t bits) {
    // base + k never carries into a tag in the top bit: indices stay below 2^31 - 32.
    push_each(bits, [base](unsigned k) { return base + k; });
  }
  /// Appends entry(k) for each bit k set in `bits`, in increasing k (as push_bits).
  template <typename E>
  KF_HD KF_INLINE void push_each(std::uint32_t bits, E&& entry) {
    // The reversed mask walked from its top bit: one FLO a push (the lowest bit costs a BREV
    // too). The slot offset runs on with a wrap (two instructions; from the count, four) and
    // the count moves once per call.
    std::uint32_t o = (c_ % kStageSlots) * Stride;
    for (std::uint32_t r = reverse_bits(bits); r != 0u;) {
      const unsigned top = highest_bit(r);
      ring_[o] = entry(31u - top);
      o = (o + Stride) % (kStageSlots * Stride);
      r ^= 1u << top;
    }
    c_ += popcount(bits);
  }
  /// Writes the ring's whole groups that are not yet written.
  KF_HD KF_INLINE void flush() {
    for (; c_ - w_ >= kListGroup; w_ += kListGroup)
      if (w_ < out_.capacity)
        store_group(w_, kListGroup);
  }
  /// Writes the rest (a last group of 1-7, padded with kNoEntry) and the count.
  KF_HD KF_INLINE void finish() {
    flush();
    if (c_ > w_ && w_ < out_.capacity)
      store_group(w_, c_ - w_);
    out_.count[i_] = c_;
  }

private:
  /// Group k / 8 of the row from slots k.. of the ring (k a multiple of 8: no wrap inside).
  KF_HD KF_INLINE void store_group(std::uint32_t k, std::uint32_t m) const {
    std::uint32_t e[kListGroup];
    const std::uint32_t* s = ring_ + (k % kStageSlots) * Stride;
    KF_UNROLL
    for (std::uint32_t u = 0; u < kListGroup; ++u)
      e[u] = u < m ? s[u * Stride] : kNoEntry;
    std::uint32_t* g = out_.slot(i_, k);
    list_detail::store4(g, e[0], e[1], e[2], e[3]);
    list_detail::store4(g + 4, e[4], e[5], e[6], e[7]);
  }

  ListSink out_;
  std::size_t i_;
  std::uint32_t* ring_;
  std::uint32_t c_ = 0; // pushed
  std::uint32_t w_ = 0; // written to the row (a multiple of 8)
};

} // namespace kf
