#version 450 core
// The surface's vertices (render/SurfaceCompute), a grid vertex a thread: each of the three grid
// edges leaving vertex v toward +x, +y, +z that the zero level crosses ((f > 0) differs at its
// ends) gets one surface vertex, so the cells sharing that edge share the vertex (marching
// cubes' index list, marching_cubes.comp). Vertex v's crossings take consecutive places from
// first[v] on, in axis order; first[v] comes from an atomic counter (the order of the list is
// the GPU's; the mesh is the same). Past the list's capacity they are only counted. Position:
// linear along the edge; normal: down the field's gradient (central differences, one-sided at
// the border), as the host's marching_cubes.
layout(std430, binding = 2) readonly buffer Field { float field[]; };
layout(std430, binding = 4) writeonly buffer Vertices { float vertex[]; }; // 7 floats each
layout(std430, binding = 5) buffer Count { uint vertices_written; uint indices_written; };
layout(std430, binding = 6) writeonly buffer First { uint first[]; };
uniform ivec3 vertices;  // the grid's vertices a side
uniform float cell;
uniform vec3 origin;     // the grid's first vertex in the world
uniform uint capacity;   // vertices the list holds

uint at(ivec3 p) { return uint(p.x) + uint(vertices.x) * (uint(p.y) + uint(vertices.y) * uint(p.z)); }
float value(ivec3 p) { return field[at(p)]; }

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

void at_vertex(ivec3 v) {
  if (any(greaterThanEqual(v, vertices)))
    return;
  const float fa = value(v);
  int crossing[3];
  uint count = 0u;
  for (int a = 0; a < 3; ++a) {
    ivec3 b = v;
    b[a] += 1;
    crossing[a] = b[a] < vertices[a] && ((fa > 0.0) != (value(b) > 0.0)) ? 1 : 0;
    count += uint(crossing[a]);
  }
  if (count == 0u)
    return;
  uint o = atomicAdd(vertices_written, count);
  first[at(v)] = o;
  if (o + count > capacity)
    return;
  for (int a = 0; a < 3; ++a) {
    if (crossing[a] == 0)
      continue;
    ivec3 b = v;
    b[a] += 1;
    const float fb = value(b);
    const float s = fa / (fa - fb);
    const vec3 p = origin + cell * mix(vec3(v), vec3(b), s);
    const vec3 g = mix(gradient(v), gradient(b), s);
    const float len = length(g);
    const vec3 n = len > 0.0 ? -g / len : vec3(0.0, 0.0, 1.0);
    vertex[7u * o] = p.x;
    vertex[7u * o + 1u] = p.y;
    vertex[7u * o + 2u] = p.z;
    vertex[7u * o + 3u] = n.x;
    vertex[7u * o + 4u] = n.y;
    vertex[7u * o + 5u] = n.z;
    vertex[7u * o + 6u] = 1.0;
    ++o;
  }
}

void main() {
  for (uint e = gl_WorkGroupID.x; e < listed; e += gl_NumWorkGroups.x)
    at_vertex(point_in_block(e));
}
