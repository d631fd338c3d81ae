#version 450 core
// A lit triangle mesh (the fluid's surface, the yarns' tubes): positions and unit normals in
// world space, and a shade a vertex scaling the colour (a wet yarn's darkening).
layout(location = 0) in vec3 position;
layout(location = 1) in vec3 normal;
layout(location = 2) in float shade;
uniform mat4 view;
uniform mat4 projection;
out vec3 view_point;
out vec3 view_normal;
out float vertex_shade;
out vec4 vertex_colour; // none: mesh.frag's uniform colour
void main() {
  const vec4 p = view * vec4(position, 1.0);
  view_point = p.xyz;
  view_normal = mat3(view) * normal; // the view is a rotation and a translation
  vertex_shade = shade;
  vertex_colour = vec4(0.0);
  gl_Position = projection * p;
}
