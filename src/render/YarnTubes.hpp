#pragma once
// The knit's yarns drawn as tubes (P6): a ring of vertices around every point of the snapshot's
// yarn polylines (the Catmull-Rom curves through the stitches' bonding points, domain/Yarns),
// joined along each yarn. The rings follow rotation-minimising frames (the double reflection
// of Wang et al. 2008), so a tube does not twist where its yarn bends. A wet yarn is darker,
// C' = C (1 - alpha sqrt(s)) carried by the vertices, and a little thicker.
#include "render/FluidSurface.hpp"
#include "render/SpaceSplit.hpp"

#include <glm/glm.hpp>

#include <array>
#include <cstdint>
#include <vector>

namespace kf::render {

struct YarnStyle {
  double radius = 0;           // a dry yarn's [m] (> 0)
  int sides = 8;               // vertices a ring
  double swell = 0.1;          // a saturated yarn's radius is radius (1 + swell)
  double wet_darkening = 0.15; // alpha
};

/// The polylines of a snapshot's yarn phase: point i joins point segment[i][1] (i + 1 along a
/// yarn; i itself at a yarn's last point), s the saturation at each (empty: dry).
struct YarnPolylines {
  std::vector<glm::dvec3> x;
  std::vector<std::array<std::uint32_t, 2>> segment;
  std::vector<double> s;
};

/// What a tube needs at each yarn point, in float for the GPU (TubeRenderer builds the rings
/// from it in its vertex shader): the centre and the radius, the ring's first direction r and the
/// shade 1 - alpha sqrt(s), and b = t x r (the ring's vertex k lies at centre + radius (cos a_k r
/// + sin a_k b), a_k = 2 pi k / sides), b's w the arc length from the yarn's start; and the
/// segments drawn, by their first point (the next point closes it).
struct YarnFrames {
  std::vector<glm::vec4> centre_radius, r_shade, b;
  std::vector<std::uint32_t> drawn;
};

/// The yarns as chains of consecutive points (chain c: points start[c] .. start[c+1] - 1; the
/// last entry is the point count) and the segments drawn, by their first point: with `only`,
/// those whose first point lies in it. Checks the phase's arrays: sizes, and each segment (i, i
/// + 1) or (i, i); anything else is a kf::Error naming the point.
struct YarnChains {
  std::vector<std::uint32_t> start, drawn;
};
YarnChains yarn_chains(const YarnPolylines& yarns, const Region* only = nullptr);

/// The yarn phase as the GPU takes it (TubeRenderer::build): a point's position and saturation
/// (x, y, z, s; s = 0 dry) and its segment, read straight from a snapshot.
struct YarnPoints {
  std::vector<glm::vec4> point;
  std::vector<std::array<std::uint32_t, 2>> segment;
  // A stitch colour a point (rgb, a = 1), a = 0 where none; empty: none at all.
  std::vector<glm::vec4> colour;
};
/// With reach > 0, the segments whose box (of its two points) grown by reach meets `only`: all
/// that may show in it once their drawing is cut at its faces (a part's translucent yarns); in
/// whole groups of kYarnGroup of the list without `only`, as the volumetric yarns' level of
/// detail merges runs within such a group: a part's pieces are then the whole frame's.
constexpr int kYarnGroup = 8;
YarnChains yarn_chains(const YarnPoints& yarns, const Region* only = nullptr, double reach = 0);
/// The polylines' points in float (tests; a snapshot's are float already).
YarnPoints yarn_points(const YarnPolylines& yarns);

/// The yarns' frames (rotation-minimising along each yarn) and the segments drawn: with `only`,
/// just those whose first point lies in it. A segment's end must be its start + 1 or the start
/// itself; anything else is a kf::Error naming the point.
YarnFrames yarn_frames(const YarnPolylines& yarns, const YarnStyle& style,
                       const Region* only = nullptr);

/// The tubes' mesh (the host's, a reference for TubeRenderer's): `sides` vertices a point, normals
/// out of the tube, the shade a vertex 1 - alpha sqrt(s); two triangles a side a segment (an end
/// has no cap: the mesh is drawn lit on both faces). With `only`, just the segments whose first
/// point lies in it (sort-last: a segment is drawn whole by the rank whose box holds its start). A
/// segment's end must be its start + 1 or the start itself; anything else is a kf::Error naming the
/// point.
SurfaceMesh yarn_tubes(const YarnPolylines& yarns, const YarnStyle& style,
                       const Region* only = nullptr);

} // namespace kf::render
