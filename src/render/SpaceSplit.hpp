#pragma once
// The k-d split of a frame's particles for sort-last rendering: `parts` convex boxes, each
// holding about the same number of points, cut recursively across the longest extent of the
// points in a box at the count's quantile. Independent of the simulation's partition (a frame is
// drawn in parts of equal work whatever owned it); the same points give every rank the same boxes.
#include <glm/glm.hpp>

#include <vector>

namespace kf::render {

/// A box [lo, hi) on each axis; the outermost faces at infinity, so every point lies in one box.
struct Region {
  glm::dvec3 lo, hi;
  bool contains(const glm::dvec3& x) const {
    return glm::all(glm::greaterThanEqual(x, lo)) && glm::all(glm::lessThan(x, hi));
  }
};

/// `parts` (>= 1) boxes tiling space. A part gets ceil(k/2) of k ranks' share on one side of a
/// cut, so the counts differ by at most the points lying on a cut plane.
std::vector<Region> kd_split(std::vector<glm::dvec3> points, int parts);

/// The parts of a k-d split (kd_split's, in its order) from the nearest to the eye to the
/// farthest: along any line of sight from `eye` they are met in this order (the translucent
/// layers' "over" needs it). The split's tree is found again from the boxes (a part's k parts
/// are ceil(k/2) then the rest, one plane between them); at each cut the side holding the eye
/// comes first.
std::vector<int> visibility_order(const std::vector<Region>& parts, const glm::dvec3& eye);

} // namespace kf::render
