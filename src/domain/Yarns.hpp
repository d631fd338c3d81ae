#pragma once
// Yarns of the knitted pieces (paper §3 and §6.1): the bonding points of every stitch (Eq. 1,
// kernels/knit/Stitch_K.hpp) strung into one yarn per course, and Catmull-Rom curves through
// them. Derived from the mass points for snapshots and rendering; never fed back.
#include "core/Vec3.hpp"
#include "domain/KnitBuilder.hpp"

#include <array>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace kf {

/// Whether stitch (i, j) is purl in a chart of K/P rows repeating over wales and courses.
bool is_purl(const std::vector<std::string>& chart, int i, int j);

/// The bonding points of every yarn of a grid piece, in yarn order: yarn j (0..cells_v) runs along
/// course j through the legs of the stitches of cell row j and the head arcs of row j - 1 (the
/// first yarn has no arcs below it, the last no legs above). A mesh piece is stockinette (chart
/// unused) with yarns along strips of quads (v0 -> v1 of each quad is the course direction): one
/// per strip with the arcs of the quads below, then the arcs that have no quad above. x: all knit
/// points.
std::vector<std::vector<Vec3d>> yarn_bonding_points(const std::vector<Vec3d>& x,
                                                    const KnitPieceLayout& piece,
                                                    const std::vector<std::string>& chart);

/// A bonding point and a scalar carried with it (the knit's saturation, for wet yarns).
struct YarnPoint {
  Vec3d x;
  double s = 0;
  int wale = -1;            // the wale of the stitch it belongs to (grid pieces), else -1
  Vec3d colour{-1, -1, -1}; // a stitch colour (colour_chart), or negative: none
};

/// The colour of stitch (i, j) of a colour chart (rows repeating over courses j, letters over
/// wales i), as `colours` names it.
Vec3d stitch_colour(const std::vector<std::string>& colour_chart,
                    const std::map<char, Vec3d>& colours, int i, int j);

/// yarn_bonding_points with a per-knit-point scalar (nullptr: zero) interpolated with the same
/// Eq. 1 weights.
std::vector<std::vector<YarnPoint>> yarn_points(const std::vector<Vec3d>& x,
                                                const std::vector<double>* scalar,
                                                const KnitPieceLayout& piece,
                                                const std::vector<std::string>& chart);

/// Polylines through all yarns: `samples` Catmull-Rom points per span between bonding points.
struct YarnLines {
  std::vector<Vec3d> x;
  std::vector<double> s;           // the scalar per point (yarn_lines of YarnPoints only)
  std::vector<Vec3d> colour;       // the colour per point, a bonding point's to mid-span (ditto)
  std::vector<std::uint32_t> yarn; // yarn index of each point
  std::vector<std::array<std::uint32_t, 2>>
      segment; // per point: (i, i + 1), or (i, i) at a yarn's end
};

YarnLines yarn_lines(const std::vector<std::vector<Vec3d>>& yarns, int samples);
YarnLines yarn_lines(const std::vector<std::vector<YarnPoint>>& yarns, int samples);

} // namespace kf
