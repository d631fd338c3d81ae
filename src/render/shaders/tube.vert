#version 450 core
// The yarns' tubes built where they are drawn (render/TubeRenderer): vertex id = p sides + k is
// the k-th of point p's ring, pulled from the yarn points' frames (render/YarnTubes'
// yarn_frames; the host's yarn_tubes is the reference); the triangles come from an index list
// (tube_indices.comp). The outputs are mesh.vert's, for mesh.frag.
layout(std430, binding = 0) readonly buffer CentreRadius { vec4 centre_radius[]; };
layout(std430, binding = 1) readonly buffer RShade { vec4 r_shade[]; };
layout(std430, binding = 2) readonly buffer B { vec4 b[]; };
layout(std430, binding = 13) readonly buffer Colours { vec4 point_colour[]; }; // a > 0: given
uniform int sides;
uniform bool coloured; // the points carry stitch colours (binding 13)
uniform mat4 view;
uniform mat4 projection;
out vec3 view_point;
out vec3 view_normal;
out float vertex_shade;
out vec4 vertex_colour;

void main() {
  const uint point = uint(gl_VertexID / sides);
  const int k = gl_VertexID % sides;
  const float a = 6.28318530717959 * float(k) / float(sides);
  const vec4 cr = centre_radius[point];
  const vec4 rs = r_shade[point];
  const vec3 out_dir = cos(a) * rs.xyz + sin(a) * b[point].xyz;
  const vec3 world = cr.xyz + cr.w * out_dir;
  const vec4 p = view * vec4(world, 1.0);
  view_point = p.xyz;
  view_normal = mat3(view) * out_dir; // the view is a rotation and a translation
  vertex_shade = rs.w;
  vertex_colour = coloured ? point_colour[point] : vec4(0.0);
  clip_to_region(world);
  gl_Position = projection * p;
}
