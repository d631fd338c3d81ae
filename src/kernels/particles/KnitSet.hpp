#pragma once
// Knit mass points (paper §3): three layers of a mass-spring mesh, structure of arrays, allocated
// only when a scene has the knit module.
#include "core/Vec3.hpp"
#include "kernels/exec/Algorithms.hpp"
#include "kernels/integrate/Verlet.hpp"

#include <cstdint>

namespace kf {

/// Sentinel of KnitView::handle: the point moves freely (the integrator's "no handle").
inline constexpr std::uint32_t kFreePoint = kNoHandle;

/// Raw pointers into a KnitSet, passed by value into kernels.
template <typename T>
struct KnitView {
  Vec3<T>* x;
  Vec3<T>* v;
  Vec3<T>* a; // acceleration at the current positions (the next half kick needs it)
  T* m;       // dry mass (P3 adds the absorbed fluid mass)
  const std::uint32_t* handle; // kFreePoint, or the index of the pin/handle moving this point
  std::size_t n;
};

/// Knit points. Their order is the rest mesh's (layer, course, wale) order and never changes:
/// springs, stitches and yarns index points directly, so the set is not re-sorted (the
/// self-collision grid sorts a permutation instead).
template <typename T>
class KnitSet {
public:
  explicit KnitSet(exec::Backend b);
  std::size_t size() const { return x.size(); }
  /// Grows snugly (DeviceBuffer::resize_snug): a rank's owned points and ghosts move a little
  /// between choices.
  void resize(std::size_t n);
  /// Frees the room past size() (a rank keeping its share of the whole knit).
  void shrink_to_fit();
  KnitView<T> view();
  /// Bytes each point costs (state, springs excluded: SpringTopology reports its own).
  static std::size_t bytes_per_particle();

  exec::DeviceBuffer<Vec3<T>> x, v, a, x_rest;
  exec::DeviceBuffer<T> m;
  exec::DeviceBuffer<std::uint32_t> handle;
  exec::DeviceBuffer<std::uint8_t> layer;  // 0 front (paper's layer 1), 1 middle, 2 back
  exec::DeviceBuffer<std::uint16_t> piece; // index of the scene's [[knit.piece]]
  exec::DeviceBuffer<std::uint64_t> id;
};

} // namespace kf
