#version 450 core
// A lit triangle mesh (the fluid's surface): positions and unit normals in world space.
layout(location = 0) in vec3 position;
layout(location = 1) in vec3 normal;
uniform mat4 view;
uniform mat4 projection;
out vec3 view_point;
out vec3 view_normal;
void main() {
  const vec4 p = view * vec4(position, 1.0);
  view_point = p.xyz;
  view_normal = mat3(view) * normal; // the view is a rotation and a translation
  gl_Position = projection * p;
}
