#pragma once
// A lattice's points sorted into boxes by what a bound on each box already knows of all its
// points. The samplers decide a point by its distances to every solid; nearly all of a scene's
// points lie far from any solid's surface, where one bound on a box (ShapeBounds) decides every
// point in it. Boxes are halved until the bound decides them or they are small; only the points of
// the small undecided boxes, near a surface, are tested one by one (domain/SceneSampler). The dam
// break's walls at 8M particles: ~50M lattice points a pass, each with a distance, before.
#include "core/Vec3.hpp"

#include <algorithm>
#include <array>
#include <cstdint>
#include <functional>
#include <vector>

namespace kf {

/// A class no box was found uniform for: the point is to be tested alone.
inline constexpr std::uint8_t kSieveMaybe = 255;

/// What holds at every point within `spread` of the box [lo, hi]: a class of the caller's (below
/// kSieveMaybe), or kSieveMaybe where the bounds cannot tell.
using BoxClassifier = std::function<std::uint8_t(const Vec3d& lo, const Vec3d& hi, double spread)>;

/// Points [lo, hi) of a lattice along each axis.
struct IndexBox {
  std::array<int, 3> lo, hi;
  bool empty() const { return hi[0] <= lo[0] || hi[1] <= lo[1] || hi[2] <= lo[2]; }
  std::uint64_t count() const {
    return empty() ? 0 : std::uint64_t(hi[0] - lo[0]) * (hi[1] - lo[1]) * (hi[2] - lo[2]);
  }
};

class LatticeSieve {
public:
  /// `axes[a]`: the points' coordinates along axis a, ascending. A point may lie up to `spread`
  /// from its lattice position (a jittered lattice). An empty `classify` leaves every point
  /// kSieveMaybe (no box bounded).
  LatticeSieve(std::array<std::vector<double>, 3> axes, double spread, BoxClassifier classify);
  /// Where undecided boxes are cut first: before point cuts[a][m] along axis a (the lattice's
  /// own seams, such as the faces a boundary lattice's shells lie behind). A box straddling one
  /// is cut there, not halved: halves of a box across a flat shell's face straddle it still.
  void cut_at(std::array<std::vector<int>, 3> cuts) { cuts_ = std::move(cuts); }

  /// Calls on_box(part, class) for boxes that cover `box` exactly, each once: decided ones
  /// (class below kSieveMaybe, at every point of the part) and small undecided ones
  /// (kSieveMaybe: at most kSmallest points, or every point alone without a classifier).
  void cover(const IndexBox& box,
             const std::function<void(const IndexBox&, std::uint8_t)>& on_box) const;
  /// The class of every point of `box`, x fastest, into `out`.
  void classes(const IndexBox& box, std::vector<std::uint8_t>& out) const;
  /// Calls to the classifier so far (tests and the set-up's figures).
  std::uint64_t classifications() const { return calls_; }

  int size(int axis) const { return static_cast<int>(axes_[axis].size()); }
  double spread() const { return spread_; }
  IndexBox whole() const { return {{0, 0, 0}, {size(0), size(1), size(2)}}; }
  /// The points of `box` whose coordinates along axis a lie in [lo - margin, hi + margin].
  IndexBox within(const IndexBox& box, const double (&lo)[3], const double (&hi)[3],
                  double margin) const;
  /// Boxes of at most this many points are not halved further: their points are tested alone.
  static constexpr int kSmallest = 64;

private:
  void split(const IndexBox& b,
             const std::function<void(const IndexBox&, std::uint8_t)>& on_box) const;

  std::array<std::vector<double>, 3> axes_;
  std::array<std::vector<int>, 3> cuts_;
  double spread_;
  BoxClassifier classify_;
  mutable std::uint64_t calls_ = 0;
};

} // namespace kf
