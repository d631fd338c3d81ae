#version 450 core
// Marching cubes, a grid cell a thread (render/SurfaceCompute; the host's marching_cubes in
// FluidSurface.cpp is the reference, with the same face-based case table). A cell's triangles
// are appended to the vertex list (position, normal, shade: MeshRenderer's layout) at a place
// taken from an atomic counter; past the list's capacity they are only counted, and the caller
// runs the pass again on a larger list. A vertex on a cell edge is computed from that edge's two
// grid values alone, so the cells sharing it give it the same bits: smooth shading without an
// index list. Normals: down the field's gradient (central differences, one-sided at the border).
layout(local_size_x = 4, local_size_y = 4, local_size_z = 4) in;
layout(std430, binding = 2) readonly buffer Field { float field[]; };
layout(std430, binding = 3) readonly buffer Cases { int cases[]; };
layout(std430, binding = 4) writeonly buffer Vertices { float vertex[]; }; // 7 floats each
layout(std430, binding = 5) buffer Count { uint written; };
uniform ivec3 vertices;  // the grid's vertices a side
uniform float cell;
uniform vec3 origin;     // the grid's first vertex in the world
uniform int stride;      // ints a case in `cases`
uniform int edge_corners[24];
uniform uint capacity;   // vertices the list holds
uniform bool limited;    // only the cells whose centres lie in [only_lo, only_hi)
uniform vec3 only_lo, only_hi;

float value(ivec3 p) {
  return field[uint(p.x) + uint(vertices.x) * (uint(p.y) + uint(vertices.y) * uint(p.z))];
}

vec3 gradient(ivec3 p) {
  vec3 g;
  for (int a = 0; a < 3; ++a) {
    ivec3 lo = p, hi = p;
    lo[a] = max(0, lo[a] - 1);
    hi[a] = min(vertices[a] - 1, hi[a] + 1);
    g[a] = (value(hi) - value(lo)) / (float(hi[a] - lo[a]) * cell);
  }
  return g;
}

ivec3 corner(ivec3 c, int k) { return c + ivec3(k & 1, (k >> 1) & 1, (k >> 2) & 1); }

void main() {
  const ivec3 c = ivec3(gl_GlobalInvocationID);
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
  const uint first = atomicAdd(written, uint(3 * triangles));
  if (first + uint(3 * triangles) > capacity)
    return;
  for (int t = 0; t < 3 * triangles; ++t) {
    const int e = cases[m * stride + 1 + t];
    const ivec3 a = corner(c, edge_corners[2 * e]), b = corner(c, edge_corners[2 * e + 1]);
    const float fa = value(a), fb = value(b);
    const float s = fa / (fa - fb);
    const vec3 p = origin + cell * mix(vec3(a), vec3(b), s);
    const vec3 g = mix(gradient(a), gradient(b), s);
    const float len = length(g);
    const vec3 n = len > 0.0 ? -g / len : vec3(0.0, 0.0, 1.0);
    const uint o = 7u * (first + uint(t));
    vertex[o] = p.x;
    vertex[o + 1u] = p.y;
    vertex[o + 2u] = p.z;
    vertex[o + 3u] = n.x;
    vertex[o + 4u] = n.y;
    vertex[o + 5u] = n.z;
    vertex[o + 6u] = 1.0;
  }
}
