#include "io/Frame.hpp"

#include "core/Error.hpp"

#include <cstring>

namespace kf::io {

std::size_t dtype_size(DType t) {
  switch (t) {
  case DType::F32:
    return 4;
  case DType::F64:
    return 8;
  case DType::U32:
    return 4;
  case DType::U64:
    return 8;
  case DType::I32:
    return 4;
  }
  return 0;
}

template <typename T>
static constexpr DType dtype_of() {
  if constexpr (std::is_same_v<T, float>)
    return DType::F32;
  else if constexpr (std::is_same_v<T, double>)
    return DType::F64;
  else if constexpr (std::is_same_v<T, std::uint32_t>)
    return DType::U32;
  else if constexpr (std::is_same_v<T, std::uint64_t>)
    return DType::U64;
  else
    return DType::I32;
}

template <typename T>
Field Field::from(std::string name, const std::vector<T>& v, int components) {
  if (components <= 0 || v.size() % components != 0)
    throw Error("field '" + name + "': " + std::to_string(v.size()) +
                " values do not make rows of " + std::to_string(components));
  Field f;
  f.name = std::move(name);
  f.type = dtype_of<T>();
  f.components = components;
  f.count = v.size() / components;
  f.bytes.resize(v.size() * sizeof(T));
  if (!v.empty())
    std::memcpy(f.bytes.data(), v.data(), f.bytes.size());
  return f;
}

template <typename T>
std::vector<T> Field::as() const {
  if (type != dtype_of<T>())
    throw Error("field '" + name + "' holds another element type than the one asked for");
  std::vector<T> v(bytes.size() / sizeof(T));
  if (!v.empty())
    std::memcpy(v.data(), bytes.data(), bytes.size());
  return v;
}

#define KF_FIELD_TYPES(X) X(float) X(double) X(std::uint32_t) X(std::uint64_t) X(std::int32_t)
#define KF_INSTANTIATE(T)                                                                          \
  template Field Field::from<T>(std::string, const std::vector<T>&, int);                          \
  template std::vector<T> Field::as<T>() const;
KF_FIELD_TYPES(KF_INSTANTIATE)
#undef KF_INSTANTIATE
#undef KF_FIELD_TYPES

const Field* Phase::find(const std::string& field) const {
  for (const auto& f : fields)
    if (f.name == field)
      return &f;
  return nullptr;
}

bool Frame::shared(const std::string& phase) const {
  for (const auto& p : shared_phases)
    if (p == phase)
      return true;
  return false;
}

const Phase* Frame::find(const std::string& phase) const {
  for (const auto& p : phases)
    if (p.name == phase)
      return &p;
  return nullptr;
}

} // namespace kf::io
