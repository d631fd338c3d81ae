#version 450 core
// A volumetric yarn's slice (render/VolumeYarns), its corners built where drawn: quad
// quads - 1 - gl_VertexID / 6 of the sorted order (the farthest first: back to front), decoded
// (yarn_slices.comp's code) into its segment, stack and slice. Across the yarn (stack 0) a
// slice is the section at its place along the segment, spanned by the frame there; along it
// (stacks 1, 2) a ribbon from the frame at one point to the next, offset along b or r. Out: the
// place in the section in units of the lumislice's half side (x along r, y along b), the twist
// angle there, the path a line of sight crosses between two slices [R], the light's direction
// in the section's plane, the share of the light that reaches the segment (yarn_slices.comp's).
layout(std430, binding = 0) readonly buffer CentreRadius { vec4 centre_radius[]; };
layout(std430, binding = 1) readonly buffer RShade { vec4 r_shade[]; };
layout(std430, binding = 2) readonly buffer B { vec4 b[]; }; // w: the arc length
layout(std430, binding = 3) readonly buffer Drawn { uint drawn[]; };
layout(std430, binding = 9) readonly buffer Codes { uint code[]; };
layout(std430, binding = 10) readonly buffer Lit { float segment_lit[]; };
uniform uint quads;
uniform uint slices;
uniform float reach;
uniform float twist; // radians a metre of yarn
uniform vec3 toward_light; // world, unit
uniform mat4 view;
uniform mat4 projection;
uniform mat4 inverse_view;
out vec2 section;
out float angle;
out float shade;
out float path;
out vec2 light_in_section;
out float lit;

const ivec2 corner[6] =
    ivec2[6](ivec2(-1, -1), ivec2(1, -1), ivec2(1, 1), ivec2(-1, -1), ivec2(1, 1), ivec2(-1, 1));

void main() {
  const uint c = code[quads - 1u - uint(gl_VertexID / 6)];
  const uint s = c >> 4, stack = (c >> 2) & 3u, j = c & 3u;
  const ivec2 k = corner[gl_VertexID % 6];
  const uint i = drawn[s];
  const float o = -1.0 + (2.0 * float(j) + 1.0) / float(slices);
  const vec3 p0 = centre_radius[i].xyz, p1 = centre_radius[i + 1u].xyz;
  vec3 r, n, normal, centre;
  float radius, arc;
  vec2 l;
  if (stack == 0u) {
    const float u = 0.5 * (o + 1.0);
    centre = mix(p0, p1, u);
    r = normalize(mix(r_shade[i].xyz, r_shade[i + 1u].xyz, u));
    n = normalize(mix(b[i].xyz, b[i + 1u].xyz, u));
    radius = mix(centre_radius[i].w, centre_radius[i + 1u].w, u);
    arc = mix(b[i].w, b[i + 1u].w, u);
    shade = mix(r_shade[i].w, r_shade[i + 1u].w, u);
    l = vec2(k);
    const vec3 d = p1 - p0;
    normal = dot(d, d) > 0.0 ? normalize(d) : cross(r, n);
    path = length(d) / (float(slices) * radius);
  } else {
    const uint e = k.x < 0 ? i : i + 1u;
    centre = centre_radius[e].xyz;
    r = r_shade[e].xyz;
    n = b[e].xyz;
    radius = centre_radius[e].w;
    arc = b[e].w;
    shade = r_shade[e].w;
    l = stack == 1u ? vec2(float(k.y), o) : vec2(o, float(k.y));
    normal = stack == 1u ? n : r;
    path = 2.0 * reach / float(slices);
  }
  const vec3 world = centre + radius * reach * (l.x * r + l.y * n);
  const vec4 p = view * vec4(world, 1.0);
  // Between two slices a line of sight crosses spacing / |cos| of the slices' normal.
  path /= max(abs(dot(normal, normalize(mat3(inverse_view) * p.xyz))), 0.2);
  section = l;
  angle = twist * arc;
  light_in_section = vec2(dot(toward_light, r), dot(toward_light, n));
  lit = segment_lit[s];
  gl_Position = projection * p;
}
