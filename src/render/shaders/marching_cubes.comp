#version 450 core
// Marching cubes, a grid cell a thread (render/SurfaceCompute; the host's marching_cubes in
// FluidSurface.cpp is the reference, with the same face-based case table): a cell's triangles
// appended to the index list at a place taken from an atomic counter (past the list's capacity
// only counted, and the caller runs the passes again on larger lists). A triangle's corner on
// the cube edge from corner a to corner b (a the lower) is the vertex that
// surface_vertices.comp gave that grid edge: first[a] plus the crossings of a's edges along the
// axes before this one.
layout(std430, binding = 2) readonly buffer Field { float field[]; };
layout(std430, binding = 3) readonly buffer Cases { int cases[]; };
layout(std430, binding = 5) buffer Count { uint vertices_written; uint indices_written; };
layout(std430, binding = 6) readonly buffer First { uint first[]; };
layout(std430, binding = 7) writeonly buffer Indices { uint index[]; };
uniform ivec3 vertices;  // the grid's vertices a side
uniform float cell;
uniform vec3 origin;     // the grid's first vertex in the world
uniform int stride;      // ints a case in `cases`
uniform int edge_corners[24];
uniform uint capacity;   // indices the list holds
uniform bool limited;    // only the cells whose centres lie in [only_lo, only_hi)
uniform vec3 only_lo, only_hi;

uint at(ivec3 p) { return uint(p.x) + uint(vertices.x) * (uint(p.y) + uint(vertices.y) * uint(p.z)); }
float value(ivec3 p) { return field[at(p)]; }
ivec3 corner(ivec3 c, int k) { return c + ivec3(k & 1, (k >> 1) & 1, (k >> 2) & 1); }

/// The surface vertex on the grid edge from p along `axis`.
uint edge_vertex(ivec3 p, int axis) {
  const bool inside = value(p) > 0.0;
  uint o = first[at(p)];
  for (int a = 0; a < axis; ++a) {
    ivec3 b = p;
    b[a] += 1;
    if (b[a] < vertices[a] && (value(b) > 0.0) != inside)
      ++o;
  }
  return o;
}

void at_cell(ivec3 c) {
  if (any(greaterThanEqual(c, vertices - 1)))
    return;
  if (limited) {
    const vec3 centre = origin + cell * (vec3(c) + 0.5);
    if (any(lessThan(centre, only_lo)) || any(greaterThanEqual(centre, only_hi)))
      return;
  }
  int m = 0;
  for (int k = 0; k < 8; ++k)
    if (value(corner(c, k)) > 0.0)
      m |= 1 << k;
  const int triangles = cases[m * stride];
  if (triangles == 0)
    return;
  const uint o = atomicAdd(indices_written, uint(3 * triangles));
  if (o + uint(3 * triangles) > capacity)
    return;
  for (int t = 0; t < 3 * triangles; ++t) {
    const int e = cases[m * stride + 1 + t];
    const int a = edge_corners[2 * e], b = edge_corners[2 * e + 1];
    index[o + uint(t)] = edge_vertex(corner(c, a), findLSB(a ^ b));
  }
}

void main() {
  for (uint e = gl_WorkGroupID.x; e < listed; e += gl_NumWorkGroups.x)
    at_cell(point_in_block(e));
}
