#pragma once
// The surface tests' shared case and check (header only: the render tests alone link
// kf_render): a ball of lattice points, and a mesh's unmatched edges.
#include "render/FluidSurface.hpp"

#include <cstddef>
#include <cstdint>
#include <map>
#include <utility>
#include <vector>

namespace kf::test {

/// Lattice points of spacing dp inside a ball of `cells` spacings' radius, centred at c.
inline std::vector<glm::dvec3> lattice_ball(int cells, glm::dvec3 c, double dp) {
  std::vector<glm::dvec3> p;
  for (int i = -cells; i <= cells; ++i)
    for (int j = -cells; j <= cells; ++j)
      for (int k = -cells; k <= cells; ++k)
        if (i * i + j * j + k * k <= cells * cells)
          p.push_back(c + dp * glm::dvec3(i, j, k));
  return p;
}

/// Edges not used exactly once in each direction: 0 for a closed, consistently oriented mesh.
inline std::size_t unmatched_edges(const render::SurfaceMesh& m) {
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> count;
  for (std::size_t t = 0; t + 2 < m.index.size(); t += 3)
    for (int e = 0; e < 3; ++e)
      ++count[{m.index[t + std::size_t(e)], m.index[t + std::size_t((e + 1) % 3)]}];
  std::size_t bad = 0;
  for (const auto& [edge, n] : count) {
    const auto back = count.find({edge.second, edge.first});
    bad += n != 1 || back == count.end() || back->second != 1;
  }
  return bad;
}

} // namespace kf::test
