#version 450 core
// The tubes' index list (render/TubeRenderer), a drawn segment a thread: segment s joins the
// rings of points p = drawn[s] and p + 1, vertex p sides + k being ring p's k-th (tube.vert).
// Side k: (ring k, ring k+1, next k+1), (ring k, next k+1, next k), counter-clockwise seen
// from outside. With step 2, every other ring vertex: a tube of half the sides inscribed in it
// (the shadow maps'). Indexed, consecutive segments share a ring's vertices, so the GPU shades a ring
// once instead of six times.
layout(local_size_x = 64) in;
layout(std430, binding = 3) readonly buffer Drawn { uint drawn[]; };
layout(std430, binding = 4) writeonly buffer Indices { uint index[]; };
uniform uint segments;
uniform uint sides;
uniform uint step; // 1, or 2 (sides even)

void main() {
  const uint s = gl_GlobalInvocationID.x;
  if (s >= segments)
    return;
  const uint ring = drawn[s] * sides, next = ring + sides;
  const uint n = sides / step;
  uint o = s * 6u * n;
  for (uint j = 0u; j < n; ++j) {
    const uint k = j * step, k1 = ((j + 1u) % n) * step;
    index[o] = ring + k;
    index[o + 1u] = ring + k1;
    index[o + 2u] = next + k1;
    index[o + 3u] = ring + k;
    index[o + 4u] = next + k1;
    index[o + 5u] = next + k;
    o += 6u;
  }
}
