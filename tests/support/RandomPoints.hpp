#pragma once
// Seeded points spread uniformly over a box (decomposition and ghost-selection tests).
#include "core/Vec3.hpp"

#include <cstdint>
#include <random>
#include <vector>

namespace kf::test {

inline std::vector<Vec3d> uniform_points(std::size_t n, const Vec3d& lo, const Vec3d& hi,
                                         std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<Vec3d> x(n);
  for (auto& q : x)
    q = {lo.x + u(rng) * (hi.x - lo.x), lo.y + u(rng) * (hi.y - lo.y),
         lo.z + u(rng) * (hi.z - lo.z)};
  return x;
}

} // namespace kf::test
