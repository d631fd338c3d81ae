#pragma once
// Vec3 arrays <-> the flat component arrays of snapshot fields, and required-field lookup.
#include "core/Error.hpp"
#include "core/Vec3.hpp"
#include "io/Frame.hpp"

#include <vector>

namespace kf {

template <typename T>
std::vector<T> flatten(const std::vector<Vec3<T>>& v) {
  std::vector<T> out(3 * v.size());
  for (std::size_t i = 0; i < v.size(); ++i) {
    out[3 * i] = v[i].x;
    out[3 * i + 1] = v[i].y;
    out[3 * i + 2] = v[i].z;
  }
  return out;
}

template <typename T>
std::vector<Vec3<T>> unflatten(const std::vector<T>& v) {
  std::vector<Vec3<T>> out(v.size() / 3);
  for (std::size_t i = 0; i < out.size(); ++i)
    out[i] = {v[3 * i], v[3 * i + 1], v[3 * i + 2]};
  return out;
}

inline const io::Field& require(const io::Phase& p, const std::string& name) {
  const io::Field* f = p.find(name);
  if (!f)
    throw Error("snapshot phase '" + p.name + "' has no field '" + name + "'");
  return *f;
}

} // namespace kf
