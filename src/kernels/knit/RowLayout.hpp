#pragma once
// Where a point's e-th entry of a per-point table (its springs, its volume cells) sits. The GPU
// reads slot-major (ELL: entry e of point i at e * n + i), so a warp's lanes, one point each, read
// adjacent words. The CPU walks one point's row at a time: there slot-major put each of a row's
// ~18 springs on its own cache line and page, and a table past the caches (the drape's 50k
// points: 15 MB of springs at least) had the force pass wait on memory; row-major (i * width + e)
// read the same sums 1.75x sooner on one core (docs/PERFORMANCE.md).
#include "core/HostDevice.hpp"
#include "kernels/exec/Backend.hpp"

#include <cstddef>
#include <cstdint>

namespace kf {

struct RowLayout {
  std::size_t slot = 0;  // the distance between a point's entries e and e + 1
  std::size_t point = 0; // the distance between points i and i + 1's entries e

  KF_HD KF_INLINE std::size_t at(std::uint32_t e, std::size_t i) const {
    return e * slot + i * point;
  }

  /// The layout the backend reads fastest for n points of at most `width` entries each.
  static RowLayout for_backend(exec::Backend b, std::size_t n, std::uint32_t width) {
    return b == exec::Backend::Cpu ? RowLayout{1, width} : RowLayout{n, 1};
  }
};

} // namespace kf
