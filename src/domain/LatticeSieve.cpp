#include "domain/LatticeSieve.hpp"

#include "core/Error.hpp"

#include <cmath>
#include <string>

namespace kf {

LatticeSieve::LatticeSieve(std::array<std::vector<double>, 3> axes, double spread,
                           BallClassifier classify)
    : axes_(std::move(axes)), spread_(spread), classify_(std::move(classify)) {
  for (const auto& a : axes_)
    for (std::size_t i = 1; i < a.size(); ++i)
      if (!(a[i - 1] <= a[i]))
        throw Error("internal: a lattice's coordinates along an axis are not ascending (at " +
                    std::to_string(i) + ")");
}

void LatticeSieve::classify_layers(int k0, int k1, std::vector<std::uint8_t>& out) const {
  out.assign(std::size_t(k1 - k0) * size(1) * size(0), kSieveMaybe);
  if (out.empty() || !classify_)
    return; // no classifier: every point alone
  split(IndexBox{{0, 0, k0}, {size(0), size(1), k1}}, k0, out);
}

void LatticeSieve::split(const IndexBox& b, int k0, std::vector<std::uint8_t>& out) const {
  // The box of the points' lattice positions; its half-diagonal, widened by the spread, reaches
  // every point from its centre.
  double lo[3], hi[3];
  for (int a = 0; a < 3; ++a) {
    lo[a] = axes_[a][b.lo[a]];
    hi[a] = axes_[a][b.hi[a] - 1];
  }
  const Vec3d centre{0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1]), 0.5 * (lo[2] + hi[2])};
  const double radius = 0.5 * norm(Vec3d{hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]}) + spread_;
  ++calls_;
  const std::uint8_t c = classify_(centre, radius);
  const int n[3] = {b.hi[0] - b.lo[0], b.hi[1] - b.lo[1], b.hi[2] - b.lo[2]};
  if (c == kSieveMaybe && n[0] * n[1] * n[2] > kSmallest) {
    // Halve the longest side (in metres) of those holding more than one point.
    int axis = -1;
    for (int a = 0; a < 3; ++a)
      if (n[a] > 1 && (axis < 0 || hi[a] - lo[a] > hi[axis] - lo[axis]))
        axis = a;
    IndexBox first = b, second = b;
    const int mid = b.lo[axis] + n[axis] / 2;
    first.hi[axis] = mid;
    second.lo[axis] = mid;
    split(first, k0, out);
    split(second, k0, out);
    return;
  }
  if (c == kSieveMaybe)
    return; // out is kSieveMaybe already
  const std::size_t nx = size(0), ny = size(1);
  for (int k = b.lo[2]; k < b.hi[2]; ++k)
    for (int j = b.lo[1]; j < b.hi[1]; ++j) {
      std::uint8_t* row = out.data() + (std::size_t(k - k0) * ny + j) * nx;
      std::fill(row + b.lo[0], row + b.hi[0], c);
    }
}

} // namespace kf
