// The active blocks' list (surface_compact.comp) for the passes that visit it: a work group of
// 8^3 a block, the groups striding over the list. Inserted after a compute shader's #version.
layout(local_size_x = 8, local_size_y = 8, local_size_z = 8) in;
layout(std430, binding = 9) readonly buffer Active { uint listed; uint block[]; };
uniform ivec3 blocks; // blocks a side

/// The grid point of this invocation in the list's e-th block.
ivec3 point_in_block(uint e) {
  const uint b = block[e];
  const ivec3 bc = ivec3(int(b % uint(blocks.x)), int((b / uint(blocks.x)) % uint(blocks.y)),
                         int(b / (uint(blocks.x) * uint(blocks.y))));
  return 8 * bc + ivec3(gl_LocalInvocationID);
}
