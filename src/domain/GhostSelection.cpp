#include "domain/GhostSelection.hpp"

#include "core/Error.hpp"

#include <algorithm>
#include <string>

namespace kf {

std::vector<int> neighbour_ranks(const Decomposition& d, int me, double width) {
  const BlockGrid& g = d.grid();
  const int r = g.reach(width);
  std::vector<char> near(d.ranks(), 0);
  for (int b = 0; b < g.count(); ++b) {
    if (d.owner_of_block(b) != me)
      continue;
    const auto c = g.coords(b);
    for (int k = std::max(0, c[2] - r); k <= std::min(g.nz() - 1, c[2] + r); ++k)
      for (int j = std::max(0, c[1] - r); j <= std::min(g.ny() - 1, c[1] + r); ++j)
        for (int i = std::max(0, c[0] - r); i <= std::min(g.nx() - 1, c[0] + r); ++i)
          near[d.owner_of_block(g.index(i, j, k))] = 1;
  }
  std::vector<int> out;
  for (int k = 0; k < d.ranks(); ++k)
    if (near[k] && k != me)
      out.push_back(k);
  return out;
}

GhostLists select_ghosts(const Decomposition& d, int me, std::span<const Vec3d> x, double width,
                         std::span<const std::uint8_t> wider, double wider_width) {
  if (!wider.empty() && wider.size() != x.size())
    throw Error("internal: select_ghosts: " + std::to_string(wider.size()) + " wider flags for " +
                std::to_string(x.size()) + " particles");
  GhostLists g;
  g.peers = neighbour_ranks(d, me, wider.empty() ? width : std::max(width, wider_width));
  g.send.resize(g.peers.size());
  std::vector<int> to;
  for (std::size_t i = 0; i < x.size(); ++i) {
    d.ghost_ranks(x[i], !wider.empty() && wider[i] ? std::max(width, wider_width) : width, to);
    for (int r : to) {
      const auto it = std::lower_bound(g.peers.begin(), g.peers.end(), r);
      // ghost_ranks only names ranks with a block within the width, hence within the reach.
      g.send[it - g.peers.begin()].push_back(static_cast<std::uint32_t>(i));
    }
  }
  return g;
}

} // namespace kf
