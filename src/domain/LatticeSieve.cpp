#include "domain/LatticeSieve.hpp"

#include "core/Error.hpp"

#include <cmath>
#include <string>

namespace kf {

LatticeSieve::LatticeSieve(std::array<std::vector<double>, 3> axes, double spread,
                           BoxClassifier classify)
    : axes_(std::move(axes)), spread_(spread), classify_(std::move(classify)) {
  for (const auto& a : axes_)
    for (std::size_t i = 1; i < a.size(); ++i)
      if (!(a[i - 1] <= a[i]))
        throw Error("internal: a lattice's coordinates along an axis are not ascending (at " +
                    std::to_string(i) + ")");
}

void LatticeSieve::cover(const IndexBox& box,
                         const std::function<void(const IndexBox&, std::uint8_t)>& on_box) const {
  if (box.empty())
    return;
  if (!classify_) { // every point alone
    on_box(box, kSieveMaybe);
    return;
  }
  split(box, on_box);
}

void LatticeSieve::classes(const IndexBox& box, std::vector<std::uint8_t>& out) const {
  out.assign(box.count(), kSieveMaybe);
  const std::size_t nx = box.hi[0] - box.lo[0], ny = box.hi[1] - box.lo[1];
  cover(box, [&](const IndexBox& b, std::uint8_t c) {
    if (c == kSieveMaybe)
      return; // out holds it already
    for (int k = b.lo[2]; k < b.hi[2]; ++k)
      for (int j = b.lo[1]; j < b.hi[1]; ++j) {
        std::uint8_t* row =
            out.data() + (std::size_t(k - box.lo[2]) * ny + (j - box.lo[1])) * nx - box.lo[0];
        std::fill(row + b.lo[0], row + b.hi[0], c);
      }
  });
}

IndexBox LatticeSieve::within(const IndexBox& box, const double (&lo)[3], const double (&hi)[3],
                              double margin) const {
  IndexBox r = box;
  for (int a = 0; a < 3; ++a) {
    const auto& x = axes_[a];
    const auto first = x.begin() + box.lo[a], last = x.begin() + box.hi[a];
    r.lo[a] = static_cast<int>(std::lower_bound(first, last, lo[a] - margin) - x.begin());
    r.hi[a] = static_cast<int>(std::upper_bound(first, last, hi[a] + margin) - x.begin());
  }
  return r;
}

void LatticeSieve::split(const IndexBox& b,
                         const std::function<void(const IndexBox&, std::uint8_t)>& on_box) const {
  // The box of the points' lattice positions; every point lies within the spread of it.
  double lo[3], hi[3];
  for (int a = 0; a < 3; ++a) {
    lo[a] = axes_[a][b.lo[a]];
    hi[a] = axes_[a][b.hi[a] - 1];
  }
  ++calls_;
  const std::uint8_t c = classify_(Vec3d{lo[0], lo[1], lo[2]}, Vec3d{hi[0], hi[1], hi[2]}, spread_);
  const int n[3] = {b.hi[0] - b.lo[0], b.hi[1] - b.lo[1], b.hi[2] - b.lo[2]};
  if (c == kSieveMaybe)
    for (int a = 0; a < 3; ++a) // the lattice's seams first, the longest side's first
      for (const int cut : cuts_[a])
        if (cut > b.lo[a] && cut < b.hi[a]) {
          IndexBox first = b, second = b;
          first.hi[a] = cut;
          second.lo[a] = cut;
          split(first, on_box);
          split(second, on_box);
          return;
        }
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
    split(first, on_box);
    split(second, on_box);
    return;
  }
  on_box(b, c);
}

} // namespace kf
