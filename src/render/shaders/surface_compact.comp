#version 450 core
// The flagged blocks (surface_blocks.comp) listed, a block a thread; the passes after it visit
// the list (render/SurfaceCompute).
layout(local_size_x = 64) in;
layout(std430, binding = 8) readonly buffer Flags { uint flag[]; };
layout(std430, binding = 9) buffer Active { uint listed; uint block[]; };
uniform uint total; // blocks in the grid

void main() {
  const uint b = gl_GlobalInvocationID.x;
  if (b < total && flag[b] != 0u)
    block[atomicAdd(listed, 1u)] = b;
}
