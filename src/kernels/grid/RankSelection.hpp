#pragma once
// The choices of a rebuild on N ranks, made where the particles are (DESIGN §6): each particle's
// new owner (or its leaving the domain) and the other ranks that need it as a ghost, from the
// blocks' owners (BlockOwners_K.hpp), in one pass over the positions on the backend. Only the
// indices of the few that move or are sent then go to the host; the owned particles' positions
// never do.
#include "kernels/exec/Algorithms.hpp"
#include "kernels/grid/BlockOwners_K.hpp"
#include "kernels/grid/GridGeometry.hpp"

#include <array>
#include <cstddef>
#include <cstdint>

namespace kf {

/// The blocks and their owners (a block's rank), the table in ex.backend's memory.
struct BlockOwners {
  BlockGridView grid;
  const int* owner = nullptr;
};

/// A departure's destination for a ghost this rank held (kept between sorts): dropped here, sent
/// nowhere, not counted as fluid that left the domain (-1).
constexpr int kGhostDropped = -2;

/// For i < n: dest[i] = kGhostDropped where `owned` is given and owned[i] is 0, else -1 where x[i]
/// lies past [lo, hi] on a side without a wall (walls: low x, high x, low y, ...; a NaN counts as
/// inside), else the owner of x[i]'s block; leaving[i] = 1 where dest[i] is another rank or -1,
/// else 0; stay[i] (where given) = 1 where dest[i] == me, else 0.
template <typename T>
void block_destinations(const exec::Exec& ex, const Vec3<T>* x, std::size_t n,
                        const BlockOwners& owners, const Vec3<T>& lo, const Vec3<T>& hi,
                        const std::array<bool, 6>& walls, int me, int* dest, std::uint32_t* leaving,
                        const std::uint32_t* owned = nullptr, std::uint32_t* stay = nullptr);

/// counts[b] += the points among the first n of x in block b of `grid` (where `only` is given,
/// those with only[i] != 0): a re-partition's counts, where the positions are (counts zeroed by
/// the caller, one a block, in ex.backend's memory).
template <typename T>
void block_counts(const exec::Exec& ex, const Vec3<T>* x, std::size_t n, const BlockGridView& grid,
                  const std::uint32_t* only, std::uint32_t* counts);

/// A wider ghost width for the points of some cells: those in a cell of `geo` flagged in `cells`
/// (per linear cell; null: none) go to the ranks within `width` of them. The fluid beside walls:
/// a peer's ghost walls then find all their fluid there and compute their own pressure.
template <typename T>
struct WiderCells {
  GridGeometry<T> geo{};
  const std::uint8_t* cells = nullptr;
  double width = 0;
  KF_HD KF_INLINE bool flags(const Vec3<T>& x) const {
    int cx, cy, cz;
    geo.coords(x, cx, cy, cz);
    return cells[geo.linear(cx, cy, cz)] != 0;
  }
  /// The ghost width of a point at x when the others' is `base`.
  KF_HD KF_INLINE double width_at(const Vec3<T>& x, double base) const {
    return cells && width > base && flags(x) ? width : base;
  }
};

/// For i < n: bit s of mask[i] is set where x[i] lies within `width` of a block of the rank whose
/// peer slot (slot_of_rank[rank], -1 for none) is first_slot + s, s < 64: a window of 64 peers a
/// pass; `wider.width` for the points in wider's flagged cells. reach: BlockGrid::reach of the
/// larger width. Where `alive` is given, mask[i] = 0 where alive[i] is 0 (a row a rebuild left in
/// place for the sort to drop).
template <typename T>
void ghost_peer_masks(const exec::Exec& ex, const Vec3<T>* x, std::size_t n,
                      const BlockOwners& owners, double width, int reach, const int* slot_of_rank,
                      int first_slot, std::uint64_t* mask, const std::uint32_t* alive = nullptr,
                      const WiderCells<T>& wider = {});

/// flags[i] = bit `bit` of mask[i], for i < n.
void mask_bit_flags(const exec::Exec& ex, const std::uint64_t* mask, std::size_t n, int bit,
                    std::uint32_t* flags);
/// inv[perm[k]] = k for k < n (perm a permutation of 0 .. n - 1).
void invert_permutation(const exec::Exec& ex, const std::uint32_t* perm, std::size_t n,
                        std::uint32_t* inv);
/// flags[k] = 1 where (perm ? perm[k] : k) < bound, else 0, for k < n: which particles were among
/// the first `bound` before a reordering perm (the owned ones, the ghosts following them).
void flag_below(const exec::Exec& ex, const std::uint32_t* perm, std::size_t n, std::size_t bound,
                std::uint32_t* flags);

} // namespace kf
