#include "render/SpaceSplit.hpp"

#include "core/Error.hpp"

#include <algorithm>
#include <limits>

namespace kf::render {

namespace {

void split(std::vector<glm::dvec3>::iterator first, std::vector<glm::dvec3>::iterator last,
           Region box, int parts, std::vector<Region>& out) {
  const auto n = std::size_t(last - first);
  if (parts == 1 || n == 0) {
    // With no points left, the remaining parts are empty boxes (a rank with nothing to draw).
    out.push_back(box);
    for (int k = 1; k < parts; ++k)
      out.push_back({box.hi, box.hi});
    return;
  }
  glm::dvec3 lo(std::numeric_limits<double>::infinity()), hi(-lo);
  for (auto it = first; it != last; ++it) {
    lo = glm::min(lo, *it);
    hi = glm::max(hi, *it);
  }
  const glm::dvec3 extent = hi - lo;
  const int axis =
      extent.x >= extent.y && extent.x >= extent.z ? 0 : (extent.y >= extent.z ? 1 : 2);
  const int left = (parts + 1) / 2;
  auto mid = first + std::ptrdiff_t(n * std::size_t(left) / std::size_t(parts));
  std::nth_element(first, mid, last,
                   [axis](const glm::dvec3& a, const glm::dvec3& b) { return a[axis] < b[axis]; });
  const double cut = mid == last ? hi[axis] : (*mid)[axis];
  // Points equal to the cut belong to the right box ([lo, hi)): move them there.
  auto right = std::partition(first, last, [&](const glm::dvec3& p) { return p[axis] < cut; });
  Region a = box, b = box;
  a.hi[axis] = cut;
  b.lo[axis] = cut;
  split(first, right, a, left, out);
  split(right, last, b, parts - left, out);
}

} // namespace

std::vector<Region> kd_split(std::vector<glm::dvec3> points, int parts) {
  if (parts < 1)
    throw Error("render: a k-d split into " + std::to_string(parts) + " parts");
  const double inf = std::numeric_limits<double>::infinity();
  std::vector<Region> out;
  split(points.begin(), points.end(), {glm::dvec3(-inf), glm::dvec3(inf)}, parts, out);
  return out;
}

} // namespace kf::render
