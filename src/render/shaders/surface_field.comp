#version 450 core
// The fluid's surface field at a grid vertex a thread (render/SurfaceCompute; the host's
// surface_field in FluidSurface.cpp is the reference it is tested against). Positions are
// relative to the grid's origin (float keeps them to 1e-7 of the box). Particles are binned in
// cubes of the kernel's reach; a vertex gathers the 27 bins around its own.
//   naive     sum_j V W(x - x_j) - 1/2, W the cubic spline of support `reach`;
//   weighted  radius - |x - xbar|, xbar the mean of the points within reach weighted by
//             (1 - r^2/reach^2)^3 (Zhu & Bridson 2005); -reach where no point is within reach.
layout(std430, binding = 0) readonly buffer Points { vec4 point[]; }; // sorted by bin
layout(std430, binding = 1) readonly buffer BinStart { uint bin_start[]; };
layout(std430, binding = 2) writeonly buffer Field { float field[]; };
uniform ivec3 vertices;  // the grid's vertices a side
uniform float cell;      // the grid's cell
uniform ivec3 bins;      // bins a side
uniform float bin_size;  // a bin's edge (the reach)
uniform float reach;     // the kernel's support
uniform float volume;    // a particle's (naive)
uniform float radius;    // the weighted field's r
uniform bool weighted;
uniform bool limited;    // only the vertices in [near_lo, near_hi) computed, the others -reach
uniform vec3 near_lo, near_hi;

const float kPi = 3.14159265358979;

float cubic_spline(float r, float h) {
  const float q = r / h, sigma = 1.0 / (kPi * h * h * h);
  if (q < 1.0)
    return sigma * (1.0 - 1.5 * q * q + 0.75 * q * q * q);
  if (q < 2.0)
    return sigma * 0.25 * (2.0 - q) * (2.0 - q) * (2.0 - q);
  return 0.0;
}

void at_vertex(ivec3 v) {
  if (any(greaterThanEqual(v, vertices)))
    return;
  const uint at = uint(v.x) + uint(vertices.x) * (uint(v.y) + uint(vertices.y) * uint(v.z));
  const vec3 x = cell * vec3(v);
  if (limited && (any(lessThan(x, near_lo)) || any(greaterThanEqual(x, near_hi)))) {
    field[at] = -reach;
    return;
  }
  const ivec3 c = clamp(ivec3(floor(x / bin_size)), ivec3(0), bins - 1);
  const ivec3 lo = max(c - 1, ivec3(0)), hi = min(c + 1, bins - 1);
  const float r2max = reach * reach;
  float sum = 0.0, wsum = 0.0;
  vec3 offset = vec3(0.0); // sum of w (x_j - x)
  for (int k = lo.z; k <= hi.z; ++k)
    for (int j = lo.y; j <= hi.y; ++j) {
      const uint row = uint(bins.x) * (uint(j) + uint(bins.y) * uint(k));
      // The bins of a row are consecutive: one run of points.
      const uint first = bin_start[row + uint(lo.x)], last = bin_start[row + uint(hi.x) + 1u];
      for (uint s = first; s < last; ++s) {
        const vec3 d = point[s].xyz - x;
        const float r2 = dot(d, d);
        if (r2 >= r2max)
          continue;
        if (weighted) {
          const float q = 1.0 - r2 / r2max;
          const float w = q * q * q;
          wsum += w;
          offset += w * d;
        } else {
          sum += volume * cubic_spline(sqrt(r2), 0.5 * reach);
        }
      }
    }
  if (weighted)
    field[at] = wsum > 0.0 ? radius - length(offset / wsum) : -reach;
  else
    field[at] = sum - 0.5;
}

void main() {
  for (uint e = gl_WorkGroupID.x; e < listed; e += gl_NumWorkGroups.x)
    at_vertex(point_in_block(e));
}
