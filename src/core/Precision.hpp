#pragma once
#include <string_view>

namespace kf {

/// Floating-point type of the particle state, chosen at run time; both are compiled.
enum class Precision { Float, Double };

inline std::string_view to_string(Precision p) {
  return p == Precision::Float ? "float" : "double";
}

} // namespace kf
