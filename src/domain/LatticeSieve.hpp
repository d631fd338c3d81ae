#pragma once
// A lattice's points visited in order (x fastest, then y, then z), each with what a test of
// boxes of points already knows about it. The samplers decide a point by its distances to every
// solid; nearly all of a scene's points lie far from any solid's surface, where one bound on a
// box (ShapeBounds: a distance at the box's centre and the box's radius) decides every point in
// it. Boxes are halved until the bound decides them or they are small; only the points of the
// small undecided boxes, near a surface, are tested one by one. The dam break's walls at 8M
// particles: ~48M lattice points a pass, each with a distance, before.
#include "core/Vec3.hpp"

#include <algorithm>
#include <array>
#include <cstdint>
#include <functional>
#include <vector>

namespace kf {

/// A class no box was found uniform for: the point is to be tested alone.
inline constexpr std::uint8_t kSieveMaybe = 255;

/// What holds at every point within `radius` of `centre`: a class of the caller's (below
/// kSieveMaybe), or kSieveMaybe where the bounds cannot tell.
using BallClassifier = std::function<std::uint8_t(const Vec3d& centre, double radius)>;

class LatticeSieve {
public:
  /// `axes[a]`: the points' coordinates along axis a, ascending. A point may lie up to `spread`
  /// from its lattice position (a jittered lattice). An empty `classify` leaves every point
  /// kSieveMaybe (no box bounded).
  LatticeSieve(std::array<std::vector<double>, 3> axes, double spread, BallClassifier classify);

  /// Calls visit(i, j, k, class) for every point (i, j, k), in order, k slowest.
  template <typename Visit>
  void for_each(Visit&& visit) const {
    const int nx = size(0), ny = size(1), nz = size(2);
    if (nx == 0 || ny == 0 || nz == 0)
      return;
    std::vector<std::uint8_t> cls;
    for (int k0 = 0; k0 < nz; k0 += kLayers) { // a slab at a time: memory of a slab's points
      const int k1 = std::min(nz, k0 + kLayers);
      classify_layers(k0, k1, cls);
      std::size_t q = 0;
      for (int k = k0; k < k1; ++k)
        for (int j = 0; j < ny; ++j)
          for (int i = 0; i < nx; ++i, ++q)
            visit(i, j, k, cls[q]);
    }
  }

  /// The classes of layers [k0, k1), x fastest (for_each's, and tests').
  void classify_layers(int k0, int k1, std::vector<std::uint8_t>& out) const;
  /// Calls to the classifier so far (tests and the set-up's figures).
  std::uint64_t classifications() const { return calls_; }

  int size(int axis) const { return static_cast<int>(axes_[axis].size()); }
  /// Boxes of at most this many points are not halved further: their points are tested alone.
  static constexpr int kSmallest = 64;
  static constexpr int kLayers = 16;

private:
  struct IndexBox {
    std::array<int, 3> lo, hi; // [lo, hi) along each axis
  };
  void split(const IndexBox& b, int k0, std::vector<std::uint8_t>& out) const;

  std::array<std::vector<double>, 3> axes_;
  double spread_;
  BallClassifier classify_;
  mutable std::uint64_t calls_ = 0;
};

} // namespace kf
