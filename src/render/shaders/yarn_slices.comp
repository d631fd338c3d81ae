#version 450 core
// The volumetric yarns' slices and their draw order (render/VolumeYarns), a drawn segment a
// thread. A segment's volume (its two points' frames, the lumislice's reach about them) is cut by
// `slices` parallel quads of one of three orthogonal stacks: across the yarn (normal t), or along
// it, normal to b or to r; the stack whose normal lies nearest the line of sight (the classic
// choice of 2D-texture volume rendering: the slices face the eye). A slice's key is its centre's
// distance from the eye, its float bits (ordered like the distances, which are >= 0); its code
// the segment, stack and slice: (segment << 4) | (stack << 2) | slice. And the share of the light
// that reaches the segment (the shadow maps at its middle moved out of the yarn toward the light,
// so its own core does not shade it): once a segment, not at each of its slices' corners.
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer CentreRadius { vec4 centre_radius[]; };
layout(std430, binding = 1) readonly buffer RShade { vec4 r_shade[]; };
layout(std430, binding = 2) readonly buffer B { vec4 b[]; }; // w: the arc length
layout(std430, binding = 3) readonly buffer Drawn { uint drawn[]; };
layout(std430, binding = 8) writeonly buffer Keys { uint key[]; };
layout(std430, binding = 9) writeonly buffer Codes { uint code[]; };
layout(std430, binding = 10) writeonly buffer Lit { float lit[]; };
uniform uint segments;
uniform mat4 view;
uniform vec3 toward_light; // world, unit
uniform uint slices; // 1..4
uniform vec3 eye;    // world
uniform float reach; // the lumislice's half side [R]

void main() {
  const uint s = gl_GlobalInvocationID.x;
  if (s >= segments)
    return;
  const uint i = drawn[s];
  const vec3 p0 = centre_radius[i].xyz, p1 = centre_radius[i + 1u].xyz;
  const vec3 mid = 0.5 * (p0 + p1);
  const vec3 v = normalize(mid - eye);
  const vec3 d = p1 - p0;
  const vec3 t = dot(d, d) > 0.0 ? normalize(d) : cross(r_shade[i].xyz, b[i].xyz);
  const vec3 r = normalize(r_shade[i].xyz + r_shade[i + 1u].xyz);
  const vec3 n = normalize(b[i].xyz + b[i + 1u].xyz);
  const float ct = abs(dot(t, v)), cb = abs(dot(n, v)), cr = abs(dot(r, v));
  const uint stack = ct >= cb && ct >= cr ? 0u : (cb >= cr ? 1u : 2u);
  const float half_side = reach * 0.5 * (centre_radius[i].w + centre_radius[i + 1u].w);
  const vec3 out_of_yarn = mid + toward_light * half_side;
  lit[s] = light_reaching(out_of_yarn, toward_light, -(view * vec4(out_of_yarn, 1.0)).z, 1.0);
  for (uint j = 0u; j < slices; ++j) {
    const float o = -1.0 + (2.0 * float(j) + 1.0) / float(slices);
    const vec3 c = stack == 0u ? mix(p0, p1, 0.5 * (o + 1.0))
                               : mid + o * half_side * (stack == 1u ? n : r);
    key[s * slices + j] = floatBitsToUint(length(c - eye));
    code[s * slices + j] = (s << 4) | (stack << 2) | j;
  }
}
