#include "kernels/grid/RankSelection.hpp"

namespace kf {

namespace {

template <typename T>
struct Destination {
  const Vec3<T>* x;
  BlockOwners owners;
  Vec3<T> lo, hi;
  bool walls[6];
  int me;
  int* dest;
  std::uint32_t* leaving;
  const std::uint32_t* owned;
  std::uint32_t* stay;
  KF_HD KF_INLINE void operator()(std::size_t i) const {
    const Vec3<T> p = x[i];
    bool out = false;
    for (int d = 0; d < 3; ++d) {
      const T c = (&p.x)[d];
      out = out || (!walls[2 * d] && c < (&lo.x)[d]) || (!walls[2 * d + 1] && c > (&hi.x)[d]);
    }
    const int o = owned && !owned[i] ? kGhostDropped
                  : out              ? -1
                                     : owners.owner[owners.grid.block_of(vec_cast<double>(p))];
    dest[i] = o;
    leaving[i] = o != me && o != kGhostDropped ? 1u : 0u;
    if (stay)
      stay[i] = o == me ? 1u : 0u;
  }
};

template <typename T>
struct BlockCount {
  const Vec3<T>* x;
  BlockGridView grid;
  const std::uint32_t* only;
  std::uint32_t* counts;
  KF_HD KF_INLINE void operator()(std::size_t i) const {
    if (only && !only[i])
      return;
    exec::atomic_fetch_add(counts + grid.block_of(vec_cast<double>(x[i])), 1u);
  }
};

template <typename T>
struct GhostMask {
  const Vec3<T>* x;
  BlockOwners owners;
  double width;
  int reach;
  const int* slot_of_rank;
  int first_slot;
  const std::uint32_t* alive;
  std::uint64_t* mask;
  WiderCells<T> wider;
  KF_HD KF_INLINE void operator()(std::size_t i) const {
    std::uint64_t m = 0;
    if (alive && alive[i] == 0) {
      mask[i] = 0;
      return;
    }
    const int* slots = slot_of_rank;
    const int first = first_slot;
    const Vec3<T> p = x[i];
    for_each_ghost_rank(owners.grid, owners.owner, vec_cast<double>(p), wider.width_at(p, width),
                        reach, [&m, slots, first](int r) {
                          const int s = slots[r] - first;
                          if (s >= 0 && s < 64)
                            m |= std::uint64_t(1) << s;
                        });
    mask[i] = m;
  }
};

struct MaskBit {
  const std::uint64_t* mask;
  int bit;
  std::uint32_t* flags;
  KF_HD KF_INLINE void operator()(std::size_t i) const {
    flags[i] = static_cast<std::uint32_t>((mask[i] >> bit) & 1u);
  }
};

struct Invert {
  const std::uint32_t* perm;
  std::uint32_t* inv;
  KF_HD KF_INLINE void operator()(std::size_t k) const {
    inv[perm[k]] = static_cast<std::uint32_t>(k);
  }
};

struct Below {
  const std::uint32_t* perm;
  std::size_t bound;
  std::uint32_t* flags;
  KF_HD KF_INLINE void operator()(std::size_t k) const {
    const std::size_t was = perm ? perm[k] : k;
    flags[k] = was < bound ? 1u : 0u;
  }
};

} // namespace

template <typename T>
void block_destinations(const exec::Exec& ex, const Vec3<T>* x, std::size_t n,
                        const BlockOwners& owners, const Vec3<T>& lo, const Vec3<T>& hi,
                        const std::array<bool, 6>& walls, int me, int* dest, std::uint32_t* leaving,
                        const std::uint32_t* owned, std::uint32_t* stay) {
  Destination<T> f{x, owners, lo, hi, {}, me, dest, leaving, owned, stay};
  for (int k = 0; k < 6; ++k)
    f.walls[k] = walls[k];
  exec::for_each(ex, n, f, "ranks.destinations");
}

template <typename T>
void block_counts(const exec::Exec& ex, const Vec3<T>* x, std::size_t n, const BlockGridView& grid,
                  const std::uint32_t* only, std::uint32_t* counts) {
  exec::for_each(ex, n, BlockCount<T>{x, grid, only, counts}, "ranks.block_counts");
}

template <typename T>
void ghost_peer_masks(const exec::Exec& ex, const Vec3<T>* x, std::size_t n,
                      const BlockOwners& owners, double width, int reach, const int* slot_of_rank,
                      int first_slot, std::uint64_t* mask, const std::uint32_t* alive,
                      const WiderCells<T>& wider) {
  exec::for_each(
      ex, n, GhostMask<T>{x, owners, width, reach, slot_of_rank, first_slot, alive, mask, wider},
      "ranks.ghost_masks");
}

void mask_bit_flags(const exec::Exec& ex, const std::uint64_t* mask, std::size_t n, int bit,
                    std::uint32_t* flags) {
  exec::for_each(ex, n, MaskBit{mask, bit, flags}, "ranks.mask_bit");
}

void invert_permutation(const exec::Exec& ex, const std::uint32_t* perm, std::size_t n,
                        std::uint32_t* inv) {
  exec::for_each(ex, n, Invert{perm, inv}, "ranks.invert");
}

void flag_below(const exec::Exec& ex, const std::uint32_t* perm, std::size_t n, std::size_t bound,
                std::uint32_t* flags) {
  exec::for_each(ex, n, Below{perm, bound, flags}, "ranks.flag_below");
}

#define KF_INSTANTIATE(T)                                                                          \
  template void block_destinations<T>(const exec::Exec&, const Vec3<T>*, std::size_t,              \
                                      const BlockOwners&, const Vec3<T>&, const Vec3<T>&,          \
                                      const std::array<bool, 6>&, int, int*, std::uint32_t*,       \
                                      const std::uint32_t*, std::uint32_t*);                       \
  template void block_counts<T>(const exec::Exec&, const Vec3<T>*, std::size_t,                    \
                                const BlockGridView&, const std::uint32_t*, std::uint32_t*);       \
  template void ghost_peer_masks<T>(const exec::Exec&, const Vec3<T>*, std::size_t,                \
                                    const BlockOwners&, double, int, const int*, int,              \
                                    std::uint64_t*, const std::uint32_t*, const WiderCells<T>&);
KF_INSTANTIATE(float)
KF_INSTANTIATE(double)
#undef KF_INSTANTIATE

} // namespace kf
