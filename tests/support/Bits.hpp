#pragma once
// Bitwise comparison for results that must be identical, not merely close (a reorder, the same
// sums read through lists instead of a walk).
#include <cstring>
#include <vector>

namespace kf::test {

template <typename U>
bool same_bits(const std::vector<U>& a, const std::vector<U>& b) {
  return a.size() == b.size() &&
         (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(U)) == 0);
}

} // namespace kf::test
