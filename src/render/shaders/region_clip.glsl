// A sort-last part's drawing cut at its region's faces (render/RegionClip): six distances to the
// box's faces, clipped by the GPU where GL_CLIP_DISTANCE0..5 are on (a part's translucent
// yarns end at its region's planes, so the parts' layers blended in order are the whole).
uniform vec3 clip_lo;
uniform vec3 clip_hi;
out float gl_ClipDistance[6];

void clip_to_region(vec3 world) {
  gl_ClipDistance[0] = world.x - clip_lo.x;
  gl_ClipDistance[1] = world.y - clip_lo.y;
  gl_ClipDistance[2] = world.z - clip_lo.z;
  gl_ClipDistance[3] = clip_hi.x - world.x;
  gl_ClipDistance[4] = clip_hi.y - world.y;
  gl_ClipDistance[5] = clip_hi.z - world.z;
}
