#pragma once
// The springs of the knit mesh, stored per point (compressed rows): every spring appears in the
// rows of both its ends, so each point gathers its own force (no atomics, deterministic sums, the
// same code on both backends).
#include "core/Vec3.hpp"
#include "kernels/exec/Algorithms.hpp"

#include <cstdint>
#include <vector>

namespace kf {

/// Spring families of the three-layer knit model (paper Fig. 1a).
enum class SpringKind : std::uint8_t {
  Stretch,        // neighbours along a wale or a course, within a layer
  Shear,          // quad diagonals, within a layer
  Bend,           // every second point along a wale or a course, within a layer
  VolumeStraight, // the same mesh node in adjacent layers (keeps the thickness)
  VolumeDiagonal, // a node and the neighbours of its twin in the adjacent layer (resists layer
                  // shear)
};
inline constexpr int kSpringKinds = 5;

/// One spring between points i and j (host side, built once from the rest mesh).
struct Spring {
  std::uint32_t i = 0, j = 0;
  double rest = 0; // rest length [m]
  double k = 0;    // stiffness [N/m]
  double c = 0;    // damping along the spring [N s/m]
  SpringKind kind = SpringKind::Stretch;
};

template <typename T>
struct SpringView {
  const std::uint32_t* start; // row i is [start[i], start[i+1])
  const std::uint32_t* other; // the point at the other end
  const T* rest;
  const T* k;
  const T* c;
  std::size_t n_points;
};

template <typename T>
class SpringTopology {
public:
  explicit SpringTopology(exec::Backend b);
  /// Builds the rows from a spring list over n_points points; rejects i == j and indices >= n.
  void build(const std::vector<Spring>& springs, std::size_t n_points);
  SpringView<T> view() const;
  std::size_t springs() const { return springs_; }
  std::size_t bytes() const;
  /// Springs per kind, for `plan` and the summary.
  const std::vector<std::size_t>& count_by_kind() const { return by_kind_; }

private:
  exec::DeviceBuffer<std::uint32_t> start_, other_;
  exec::DeviceBuffer<T> rest_, k_, c_;
  std::size_t springs_ = 0;
  std::vector<std::size_t> by_kind_;
};

} // namespace kf
