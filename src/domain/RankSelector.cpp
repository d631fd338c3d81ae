#include "domain/RankSelector.hpp"

#include "kernels/exec/RowCopy.hpp"
#include "kernels/grid/RankSelection.hpp"

#include <algorithm>

namespace kf {

template <typename T>
RankSelector<T>::RankSelector(exec::Backend backend)
    : backend_(backend), owner_(backend, 0, "ranks.block_owner"),
      slot_(backend, 0, "ranks.peer_slot"), dest_(backend, 0, "ranks.destination"),
      picked_dest_(backend, 0, "ranks.leaver_destination"), flags_(backend, 0, "ranks.flags"),
      offsets_(backend, 0, "ranks.offsets"), idx_(backend, 0, "ranks.indices"),
      stay_(backend, 0, "ranks.stay"), counts_(backend, 0, "ranks.block_counts"),
      mask_(backend, 0, "ranks.ghost_mask"), picked_m_(backend, 0, "ranks.leaver_mass") {}

template <typename T>
void RankSelector<T>::set(const Decomposition& d, int rank) {
  decomposition_ = &d;
  rank_ = rank;
  grid_ = d.grid().view();
  owner_.assign(d.owners());
  peers_.clear();
}

template <typename T>
std::vector<std::uint32_t> RankSelector<T>::block_counts(const exec::DeviceBuffer<Vec3<T>>& x,
                                                         std::size_t n, const std::uint32_t* only) {
  if (!decomposition_)
    throw Error("internal: blocks counted before the blocks' owners were set");
  const exec::Exec ex{backend_};
  const std::size_t blocks = static_cast<std::size_t>(decomposition_->grid().count());
  counts_.resize(blocks);
  exec::fill_flags(ex, counts_.data(), blocks, 0u, "ranks.block_counts");
  kf::block_counts(ex, x.data(), n, grid_, only, counts_.data());
  std::vector<std::uint32_t> out(blocks);
  exec::copy_bytes(out.data(), exec::Backend::Cpu, counts_.data(), backend_,
                   blocks * sizeof(std::uint32_t));
  return out;
}

template <typename T>
std::vector<std::uint32_t> RankSelector<T>::indices(std::size_t n) const {
  std::vector<std::uint32_t> v(n);
  if (n)
    exec::copy_bytes(v.data(), exec::Backend::Cpu, idx_.data(), backend_,
                     n * sizeof(std::uint32_t));
  return v;
}

template <typename T>
typename RankSelector<T>::Departures
RankSelector<T>::departures(const exec::DeviceBuffer<Vec3<T>>& x, const exec::DeviceBuffer<T>& m,
                            std::size_t n, const Vec3<T>& lo, const Vec3<T>& hi,
                            const std::array<bool, 6>& walls, const std::uint32_t* owned) {
  const exec::Exec ex{backend_};
  dest_.resize(n);
  flags_.resize(n);
  stay_.resize(n);
  block_destinations(ex, x.data(), n, BlockOwners{grid_, owner_.data()}, lo, hi, walls, rank_,
                     dest_.data(), flags_.data(), owned, stay_.data());
  const std::size_t k = exec::flagged_indices(ex, flags_, offsets_, idx_, "ranks.leavers");
  Departures d;
  d.leaving.n = n;
  d.leaving.keep = stay_.data();
  d.leaving.index = indices(k);
  d.leaving.to.resize(k);
  std::vector<T> mass(k);
  if (k) {
    picked_dest_.resize(k);
    picked_m_.resize(k);
    exec::gather_rows(ex, picked_dest_.data(), dest_.data(), idx_.data(), k, sizeof(int),
                      "ranks.leavers");
    exec::gather_rows(ex, picked_m_.data(), m.data(), idx_.data(), k, sizeof(T), "ranks.leavers");
    exec::copy_bytes(d.leaving.to.data(), exec::Backend::Cpu, picked_dest_.data(), backend_,
                     k * sizeof(int));
    exec::copy_bytes(mass.data(), exec::Backend::Cpu, picked_m_.data(), backend_, k * sizeof(T));
  }
  for (std::size_t j = 0; j < k; ++j) // ascending, as the sort removing them on one rank adds
    if (d.leaving.to[j] < 0) {
      ++d.removed;
      d.removed_mass += double(mass[j]);
    }
  return d;
}

template <typename T>
template <typename Each>
std::vector<int> RankSelector<T>::choose_ghosts(const exec::DeviceBuffer<Vec3<T>>& x, std::size_t n,
                                                double width, const std::uint32_t* alive,
                                                const WiderCells<T>& wider, Each each) {
  if (!decomposition_)
    throw Error("internal: ghosts chosen before the blocks' owners were set");
  // The peers and the blocks' reach: those of the widest a point may take (every rank alike).
  const double base = width;
  if (wider.cells)
    width = std::max(width, wider.width);
  // The fluid's and the boundary's widths are fixed; the knit's changes at each choice of its
  // ghosts: the widths used last are kept (the latest at the back), the least recent dropped.
  auto it =
      std::find_if(peers_.begin(), peers_.end(), [&](const auto& p) { return p.first == width; });
  if (it == peers_.end()) {
    if (peers_.size() >= 6)
      peers_.erase(peers_.begin());
    peers_.emplace_back(width, neighbour_ranks(*decomposition_, rank_, width));
  } else {
    std::rotate(it, it + 1, peers_.end());
  }
  const std::vector<int> peers = peers_.back().second;
  if (peers.empty())
    return peers;
  std::vector<int> slot(decomposition_->ranks(), -1);
  for (std::size_t s = 0; s < peers.size(); ++s)
    slot[peers[s]] = static_cast<int>(s);
  slot_.assign(slot);
  const exec::Exec ex{backend_};
  const int reach = decomposition_->grid().reach(width);
  mask_.resize(n);
  flags_.resize(n);
  // 64 peers a pass (a rank in the middle of a 3-D split has 26).
  for (std::size_t first = 0; first < peers.size(); first += 64) {
    ghost_peer_masks(ex, x.data(), n, BlockOwners{grid_, owner_.data()}, base, reach, slot_.data(),
                     static_cast<int>(first), mask_.data(), alive, wider);
    for (std::size_t s = first; s < std::min(peers.size(), first + 64); ++s) {
      mask_bit_flags(ex, mask_.data(), n, static_cast<int>(s - first), flags_.data());
      // (the count first: the call may grow idx_)
      const std::size_t k = exec::flagged_indices(ex, flags_, offsets_, idx_, "ranks.ghosts");
      each(s, idx_.data(), k);
    }
  }
  return peers;
}

template <typename T>
typename RankSelector<T>::GhostRows
RankSelector<T>::ghost_rows(const exec::DeviceBuffer<Vec3<T>>& x, std::size_t n, double width,
                            comm::RowCopier& rows, const std::uint32_t* alive,
                            const WiderCells<T>& wider) {
  GhostRows g;
  g.peers = choose_ghosts(x, n, width, alive, wider,
                          [&](std::size_t, const std::uint32_t* idx, std::size_t k) {
                            g.send.push_back(rows.adopt(idx, k));
                          });
  return g;
}

template class RankSelector<float>;
template class RankSelector<double>;

} // namespace kf
