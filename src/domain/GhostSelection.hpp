#pragma once
// Which particles each rank sends as ghosts, chosen when the ghost set is rebuilt (DESIGN §6):
// a particle goes to every other rank whose region lies within the ghost width of it. The peer
// list is symmetric over the job (every rank derives it from the same decomposition), as the
// transports require.
#include "domain/Decomposition.hpp"

#include <cstdint>
#include <span>
#include <vector>

namespace kf {

/// The ranks whose blocks lie within `width` (in whole blocks: the same reach both ways) of rank
/// `me`'s blocks, ascending; `me` excluded. A superset of those that exchange anything.
std::vector<int> neighbour_ranks(const Decomposition& d, int me, double width);

struct GhostLists {
  std::vector<int> peers;
  std::vector<std::vector<std::uint32_t>> send; // per peer: local indices, ascending
};

/// For rank `me`'s particles x (owned, in local order): the local indices each peer needs.
/// Where `wider` is given (one flag a particle), a flagged particle goes as far as wider_width
/// (the peers are then those within it: every rank must pass the same widths).
GhostLists select_ghosts(const Decomposition& d, int me, std::span<const Vec3d> x, double width,
                         std::span<const std::uint8_t> wider = {}, double wider_width = 0);

} // namespace kf
