#version 450 core
// The yarns' frames on the GPU (render/TubeRenderer), a yarn (chain of points) a thread: what
// the host's yarn_frames (render/YarnTubes, the reference) computes, in float. Tangents by
// central differences (one-sided at a chain's ends; a point on both its neighbours keeps the
// last tangent); the ring's first direction r carried along by the double reflection (Wang et
// al. 2008), back to unit and normal to the tangent each step; b = t x r; the radius swells and
// the shade darkens with the saturation s: radius (1 + swell s), 1 - alpha sqrt(s); b's w is
// the arc length from the chain's start (the lumislice's twist, VolumeYarns).
layout(local_size_x = 64) in;
layout(std430, binding = 0) writeonly buffer CentreRadius { vec4 centre_radius[]; };
layout(std430, binding = 1) writeonly buffer RShade { vec4 r_shade[]; };
layout(std430, binding = 2) writeonly buffer B { vec4 b_out[]; };
layout(std430, binding = 5) readonly buffer Points { vec4 point[]; }; // x, y, z, saturation
layout(std430, binding = 6) readonly buffer Chains { uint chain_start[]; }; // chains + 1
uniform uint chains;
uniform float radius, swell, darkening;

vec3 tangent(uint i, uint a, uint b, vec3 last) {
  const vec3 d = point[min(i + 1u, b)].xyz - point[i > a ? i - 1u : a].xyz;
  const float len = length(d);
  return len > 0.0 ? d / len : last;
}

void main() {
  const uint c = gl_GlobalInvocationID.x;
  if (c >= chains)
    return;
  const uint a = chain_start[c], b = chain_start[c + 1u] - 1u;
  vec3 t_last = tangent(a, a, b, vec3(1.0, 0.0, 0.0));
  const vec3 axis = abs(t_last.x) < 0.9 ? vec3(1.0, 0.0, 0.0) : vec3(0.0, 1.0, 0.0);
  vec3 r = normalize(cross(t_last, axis));
  float arc = 0.0;
  for (uint i = a; i <= b; ++i) {
    if (i > a)
      arc += length(point[i].xyz - point[i - 1u].xyz);
    const vec3 t = i == a ? t_last : tangent(i, a, b, t_last);
    if (i > a) { // double reflection: from the frame at i - 1 to the one at i
      const vec3 v1 = point[i].xyz - point[i - 1u].xyz;
      const float c1 = dot(v1, v1);
      vec3 rl = r, tl = t_last;
      if (c1 > 0.0) {
        rl -= (2.0 / c1) * dot(v1, r) * v1;
        tl -= (2.0 / c1) * dot(v1, tl) * v1;
      }
      const vec3 v2 = t - tl;
      const float c2 = dot(v2, v2);
      r = c2 > 0.0 ? rl - (2.0 / c2) * dot(v2, rl) * v2 : rl;
      r = normalize(r - dot(r, t) * t);
    }
    const float s = clamp(point[i].w, 0.0, 1.0);
    centre_radius[i] = vec4(point[i].xyz, radius * (1.0 + swell * s));
    r_shade[i] = vec4(r, 1.0 - darkening * sqrt(s));
    b_out[i] = vec4(cross(t, r), arc);
    t_last = t;
  }
}
