#include "render/SpaceSplit.hpp"

#include "core/Error.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

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

namespace {

void visit(const std::vector<Region>& parts, int first, int last, const glm::dvec3& eye,
           std::vector<int>& out) {
  const int k = last - first;
  if (k == 1) {
    out.push_back(first);
    return;
  }
  const int mid = first + (k + 1) / 2;
  // The cut: the axis on which every box of the first side ends where the second side's begin.
  int axis = -1;
  double cut = 0;
  for (int a = 0; a < 3 && axis < 0; ++a) {
    double end = -std::numeric_limits<double>::infinity();
    double begin = std::numeric_limits<double>::infinity();
    for (int r = first; r < mid; ++r)
      end = std::max(end, parts[std::size_t(r)].hi[a]);
    for (int r = mid; r < last; ++r)
      begin = std::min(begin, parts[std::size_t(r)].lo[a]);
    if (end <= begin) {
      axis = a;
      cut = end;
    }
  }
  if (axis < 0)
    throw Error("render: parts " + std::to_string(first) + ".." + std::to_string(last - 1) +
                " are not a k-d split's (no plane between their halves)");
  if (eye[axis] < cut) {
    visit(parts, first, mid, eye, out);
    visit(parts, mid, last, eye, out);
  } else {
    visit(parts, mid, last, eye, out);
    visit(parts, first, mid, eye, out);
  }
}

} // namespace

std::vector<int> visibility_order(const std::vector<Region>& parts, const glm::dvec3& eye) {
  std::vector<int> out;
  if (!parts.empty())
    visit(parts, 0, int(parts.size()), eye, out);
  return out;
}

} // namespace kf::render
