#version 450 core
// A volumetric yarn's slice (render/VolumeYarns), its corners built where drawn: quad
// quads - 1 - gl_VertexID / 6 of the sorted order (the farthest first: back to front; quads
// from the indirect draw's count), its slot's piece (yarn_slices.comp's) decoded into its first
// point, the run's length, stack, slice and slice count. Across the yarn (stack 0) a slice is
// the section at its place along the piece, spanned by the frame there; along it (stacks 1, 2)
// a ribbon from the frame at one end to the other's, offset along b or r. A piece of one slice
// seen across the yarn is seen whole: a ribbon turned about the yarn to face the eye (its side
// perpendicular to the line of sight in the section's plane). Out: the place in the section in
// units of the lumislice's half side (x along r, y along b; seen whole: x the line of sight's
// offset), the twist angle there, the path a line of sight crosses between two slices [R], the
// light's and (seen whole) the line of sight's direction in the section's plane (its length the
// sine of its angle to the yarn), the share of the light that reaches the piece
// (yarn_slices.comp's).
layout(std430, binding = 0) readonly buffer CentreRadius { vec4 centre_radius[]; };
layout(std430, binding = 1) readonly buffer RShade { vec4 r_shade[]; };
layout(std430, binding = 2) readonly buffer B { vec4 b[]; }; // w: the arc length
layout(std430, binding = 9) readonly buffer Codes { uint code[]; };
layout(std430, binding = 10) readonly buffer Pieces { uvec2 piece[]; };
layout(std430, binding = 11) readonly buffer Lit { float segment_lit[]; };
layout(std430, binding = 12) readonly buffer Draw { uint vertex_count; };
layout(std430, binding = 13) readonly buffer Colours { vec4 point_colour[]; }; // a > 0: given
uniform bool coloured; // the points carry stitch colours (binding 13)
uniform uint slices; // a segment's slots
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
out vec4 stitch_colour; // a > 0: the point's (binding 13), else the uniform colour
out vec2 view_in_section;
flat out int whole;

const ivec2 corner[6] =
    ivec2[6](ivec2(-1, -1), ivec2(1, -1), ivec2(1, 1), ivec2(-1, -1), ivec2(1, 1), ivec2(-1, 1));

void main() {
  const uint slot = code[vertex_count / 6u - 1u - uint(gl_VertexID / 6)];
  const uvec2 pc = piece[slot];
  const uint i = pc.x, e = i + (pc.y & 15u) + 1u, stack = (pc.y >> 4) & 3u, j = (pc.y >> 6) & 3u;
  const uint n_slices = ((pc.y >> 8) & 3u) + 1u;
  const ivec2 k = corner[gl_VertexID % 6];
  const float o = -1.0 + (2.0 * float(j) + 1.0) / float(n_slices);
  const vec3 p0 = centre_radius[i].xyz, p1 = centre_radius[e].xyz;
  vec3 r, n, normal, centre;
  float radius, arc;
  vec2 l;
  if (stack == 0u) {
    const float u = 0.5 * (o + 1.0);
    centre = mix(p0, p1, u);
    r = normalize(mix(r_shade[i].xyz, r_shade[e].xyz, u));
    n = normalize(mix(b[i].xyz, b[e].xyz, u));
    radius = mix(centre_radius[i].w, centre_radius[e].w, u);
    arc = mix(b[i].w, b[e].w, u);
    shade = mix(r_shade[i].w, r_shade[e].w, u);
    stitch_colour = coloured ? point_colour[u < 0.5 ? i : e] : vec4(0.0);
    l = vec2(k);
    const vec3 d = p1 - p0;
    normal = dot(d, d) > 0.0 ? normalize(d) : cross(r, n);
    path = length(d) / (float(n_slices) * radius);
  } else {
    const uint end = k.x < 0 ? i : e;
    centre = centre_radius[end].xyz;
    r = r_shade[end].xyz;
    n = b[end].xyz;
    radius = centre_radius[end].w;
    arc = b[end].w;
    shade = r_shade[end].w;
    stitch_colour = coloured ? point_colour[end] : vec4(0.0);
    l = stack == 1u ? vec2(float(k.y), o) : vec2(o, float(k.y));
    normal = stack == 1u ? n : r;
    path = 2.0 * reach / float(n_slices);
  }
  whole = stack != 0u && n_slices == 1u ? 1 : 0;
  if (whole == 1) {
    // Across the line of sight to the end's centre; each corner's own line of sight (the
    // perspective: a ray at the yarn's rim leans by its offset over the distance).
    const vec3 to_centre = normalize(centre - inverse_view[3].xyz);
    vec2 w = vec2(dot(to_centre, r), dot(to_centre, n));
    w = dot(w, w) > 1e-12 ? normalize(w) : vec2(0.0, 1.0);
    l = float(k.y) * vec2(-w.y, w.x);
  }
  const vec3 world = centre + radius * reach * (l.x * r + l.y * n);
  const vec3 sight = normalize(world - inverse_view[3].xyz);
  view_in_section = vec2(dot(sight, r), dot(sight, n));
  if (whole == 1)
    normal = sight; // the path is the texture's: no slices' spacing
  const vec4 p = view * vec4(world, 1.0);
  // Between two slices a line of sight crosses spacing / |cos| of the slices' normal.
  path /= max(abs(dot(normal, normalize(mat3(inverse_view) * p.xyz))), 0.2);
  section = l;
  angle = twist * arc;
  light_in_section = vec2(dot(toward_light, r), dot(toward_light, n));
  lit = segment_lit[slot / slices];
  clip_to_region(world);
  gl_Position = projection * p;
}
