#version 450 core
// The volumetric yarns' slices and their draw order (render/VolumeYarns), a group of `group`
// drawn segments a thread. A piece of yarn (a segment, or a run of them merged) has its volume
// (its two ends' frames, the lumislice's reach about them) cut by n parallel quads of one of
// three orthogonal stacks: across the yarn (normal t), or along it, normal to b or to r; the
// stack whose normal lies nearest the line of sight (the classic choice of 2D-texture volume
// rendering: the slices face the eye).
// Level of detail (pixel_scale > 0): a piece under detail_pixels on screen takes one quad (the
// vertex shader turns it to face the eye, shaded from the lumislice seen whole, unless it is
// seen along the yarn: then one section across); a run of 2, 4 or `group` contiguous segments
// (aligned in the group) is one piece while its chord stays within merge_pixels on screen and
// its points within half a pixel of the chord (a yarn a few pixels wide and its segments under
// a pixel long: 4 slices a segment would be quads far under a pixel, the rasteriser's worst
// case). Fewer slices than 4 but more than one would show the fibres' gaps (a slice samples
// one line through the section), hence one or all.
// Out, in the slots of the piece's first segment (slots * its place + j): the slice's key, its
// centre's distance from the eye as float bits (ordered like the distances, which are >= 0), the
// slot itself (the value sorted with it) and the piece (first point; the run's length, stack,
// slice and slice count); an unused slot's key sorts last (all ones). The quads in use are
// counted into the indirect draw (6 vertices each). And the share of the light that reaches the
// piece (the shadow maps at its middle moved out of the yarn toward the light, so its own core
// does not shade it): once a piece.
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer CentreRadius { vec4 centre_radius[]; };
layout(std430, binding = 1) readonly buffer RShade { vec4 r_shade[]; };
layout(std430, binding = 2) readonly buffer B { vec4 b[]; }; // w: the arc length
layout(std430, binding = 3) readonly buffer Drawn { uint drawn[]; };
layout(std430, binding = 8) writeonly buffer Keys { uint key[]; };
layout(std430, binding = 9) writeonly buffer Codes { uint code[]; };
layout(std430, binding = 10) writeonly buffer Pieces { uvec2 piece[]; };
layout(std430, binding = 11) writeonly buffer Lit { float lit[]; }; // a segment's place
layout(std430, binding = 12) buffer Draw { uint vertex_count; };    // glDrawArraysIndirect's
uniform uint segments;
uniform mat4 view;
uniform vec3 toward_light; // world, unit
uniform uint slices;       // the most a piece, 1..4; a segment's slots
uniform vec3 eye;          // world
uniform float reach;       // the lumislice's half side [R]
uniform float pixel_scale; // pixels a metre at a metre from the eye; 0: no level of detail
uniform float detail_pixels;
uniform uint group;        // 1, 2, 4 or 8
const float merge_pixels = 8.0, straight_pixels = 0.5;

// Whether segments [first, first + count) of the drawn list are one straight, short piece.
bool mergeable(uint first, uint count) {
  const uint i = drawn[first];
  if (drawn[first + count - 1u] != i + count - 1u) // a yarn ends (or a part's cut) within
    return false;
  const vec3 p0 = centre_radius[i].xyz, p1 = centre_radius[i + count].xyz;
  const float per_metre = pixel_scale / max(length(0.5 * (p0 + p1) - eye), 1e-6);
  const vec3 d = p1 - p0;
  const float l = length(d);
  if (l * per_metre > merge_pixels)
    return false;
  const vec3 t = l > 0.0 ? d / l : vec3(0.0);
  for (uint k = 1u; k < count; ++k) {
    const vec3 q = centre_radius[i + k].xyz - p0;
    if (length(q - dot(q, t) * t) * per_metre > straight_pixels)
      return false;
  }
  return true;
}

void emit(uint first, uint count) {
  const uint i = drawn[first], e = i + count;
  const vec3 p0 = centre_radius[i].xyz, p1 = centre_radius[e].xyz;
  const vec3 mid = 0.5 * (p0 + p1);
  const float distance = length(mid - eye);
  const vec3 v = (mid - eye) / max(distance, 1e-30);
  const vec3 d = p1 - p0;
  const vec3 t = dot(d, d) > 0.0 ? normalize(d) : cross(r_shade[i].xyz, b[i].xyz);
  const vec3 r = normalize(r_shade[i].xyz + r_shade[e].xyz);
  const vec3 n = normalize(b[i].xyz + b[e].xyz);
  const float ct = abs(dot(t, v)), cb = abs(dot(n, v)), cr = abs(dot(r, v));
  const uint stack = ct >= cb && ct >= cr ? 0u : (cb >= cr ? 1u : 2u);
  const float half_side = reach * 0.5 * (centre_radius[i].w + centre_radius[e].w);
  const vec3 out_of_yarn = mid + toward_light * half_side;
  lit[first] = light_reaching(out_of_yarn, toward_light, -(view * vec4(out_of_yarn, 1.0)).z, 1.0);
  uint count_slices = slices;
  if (pixel_scale > 0.0) {
    const float size = max(length(d), 2.0 * half_side) * pixel_scale / max(distance, 1e-6);
    count_slices = size < detail_pixels ? 1u : slices;
  }
  for (uint j = 0u; j < count_slices; ++j) {
    const float o = -1.0 + (2.0 * float(j) + 1.0) / float(count_slices);
    const vec3 c = stack == 0u ? mix(p0, p1, 0.5 * (o + 1.0))
                               : mid + o * half_side * (stack == 1u ? n : r);
    const uint slot = first * slices + j;
    key[slot] = floatBitsToUint(length(c - eye));
    piece[slot] = uvec2(i, (count - 1u) | (stack << 4) | (j << 6) | ((count_slices - 1u) << 8));
  }
  atomicAdd(vertex_count, 6u * count_slices);
}

void main() {
  const uint first = gl_GlobalInvocationID.x * group;
  if (first >= segments)
    return;
  const uint count = min(group, segments - first);
  for (uint slot = first * slices; slot < (first + count) * slices; ++slot) {
    key[slot] = 0xffffffffu;
    code[slot] = slot;
  }
  for (uint k = 0u; k < count;) {
    uint m = 1u;
    if (pixel_scale > 0.0)
      for (uint l = group; l > 1u; l >>= 1)
        if (k % l == 0u && k + l <= count && mergeable(first + k, l)) {
          m = l;
          break;
        }
    emit(first + k, m);
    k += m;
  }
}
