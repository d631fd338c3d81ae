#version 450 core
// The yarns' tubes built where they are drawn (render/TubeRenderer): a vertex a thread of a
// plain draw of 6 sides-many vertices a segment, pulled from the yarn points' frames
// (render/YarnTubes' yarn_frames, the host's yarn_tubes the reference): segment s = drawn[id /
// (6 sides)] joins the rings of points s and s + 1; side k takes the triangles (ring k, ring
// k+1, next k+1) and (ring k, next k+1, next k), counter-clockwise seen from outside. The
// outputs are mesh.vert's, for mesh.frag.
layout(std430, binding = 0) readonly buffer CentreRadius { vec4 centre_radius[]; };
layout(std430, binding = 1) readonly buffer RShade { vec4 r_shade[]; };
layout(std430, binding = 2) readonly buffer B { vec4 b[]; };
layout(std430, binding = 3) readonly buffer Drawn { uint drawn[]; };
uniform int sides;
uniform mat4 view;
uniform mat4 projection;
out vec3 view_point;
out vec3 view_normal;
out float vertex_shade;

const int kRing[6] = int[6](0, 1, 1, 0, 1, 0);  // 1: the side's second corner k + 1
const int kNext[6] = int[6](0, 0, 1, 0, 1, 1);  // 1: the next point's ring

void main() {
  const int per_segment = 6 * sides;
  const int id = gl_VertexID;
  const uint point = drawn[id / per_segment] + uint(kNext[id % 6]);
  const int k = ((id % per_segment) / 6 + kRing[id % 6]) % sides;
  const float a = 6.28318530717959 * float(k) / float(sides);
  const vec4 cr = centre_radius[point];
  const vec4 rs = r_shade[point];
  const vec3 out_dir = cos(a) * rs.xyz + sin(a) * b[point].xyz;
  const vec4 p = view * vec4(cr.xyz + cr.w * out_dir, 1.0);
  view_point = p.xyz;
  view_normal = mat3(view) * out_dir; // the view is a rotation and a translation
  vertex_shade = rs.w;
  gl_Position = projection * p;
}
