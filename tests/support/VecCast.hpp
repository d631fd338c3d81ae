#pragma once
// Points built in double by a test's scene, cast to the precision under test.
#include "core/Vec3.hpp"

#include <vector>

namespace kf::test {

template <typename T>
std::vector<Vec3<T>> vec_cast_all(const std::vector<Vec3d>& a) {
  std::vector<Vec3<T>> o;
  o.reserve(a.size());
  for (const auto& q : a)
    o.push_back(vec_cast<T>(q));
  return o;
}

} // namespace kf::test
