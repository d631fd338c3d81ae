#version 450 core
// The surface grid's active blocks (render/SurfaceCompute), a particle a thread: the blocks of
// 8^3 grid vertices that hold a vertex within `margin` of a particle (the kernel's reach and two
// cells: every vertex whose field value is not the empty one, and every cell and edge touching
// such a vertex, lies in one) are flagged; the field, vertex and cube passes visit only those.
// Positions are relative to the grid's origin.
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Points { vec4 point[]; };
layout(std430, binding = 8) buffer Flags { uint flag[]; };
uniform uint points;
uniform float cell;
uniform float margin;
uniform ivec3 blocks;              // blocks a side
uniform ivec3 first_vertex, last_vertex; // the vertices that may be active (a region's near box)

void main() {
  const uint i = gl_GlobalInvocationID.x;
  if (i >= points)
    return;
  const vec3 p = point[i].xyz;
  const ivec3 lo = max(ivec3(ceil((p - margin) / cell)), first_vertex);
  const ivec3 hi = min(ivec3(floor((p + margin) / cell)), last_vertex);
  if (any(greaterThan(lo, hi)))
    return;
  const ivec3 blo = lo / 8, bhi = hi / 8;
  for (int k = blo.z; k <= bhi.z; ++k)
    for (int j = blo.y; j <= bhi.y; ++j)
      for (int b = blo.x; b <= bhi.x; ++b)
        flag[uint(b) + uint(blocks.x) * (uint(j) + uint(blocks.y) * uint(k))] = 1u;
}
