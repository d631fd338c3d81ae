#version 450 core
// One quad a sphere (4 vertices of a triangle strip, one instance a sphere), facing the camera
// and large enough to hold the sphere's silhouette under perspective; the fragment shader casts a
// ray per pixel against the sphere. Orthographic (the light's view for shadows): rays along -z,
// the quad the sphere's square.
struct Sphere {
  vec4 centre_radius;
  vec4 colour;
};
layout(std430, binding = 0) readonly buffer Spheres { Sphere spheres[]; };
uniform mat4 view;
uniform mat4 projection;
uniform bool orthographic;
out vec3 ray_point;                // the quad's point in view space
flat out vec4 centre_radius_view;  // the sphere's centre in view space, radius
flat out vec4 sphere_colour;
void main() {
  const Sphere s = spheres[gl_InstanceID];
  const vec3 c = (view * vec4(s.centre_radius.xyz, 1.0)).xyz;
  const float r = s.centre_radius.w;
  const vec2 corner = vec2(float(gl_VertexID & 1), float(gl_VertexID >> 1)) * 2.0 - 1.0;
  // A quad through the sphere's front, scaled by distance so that its silhouette (a cone from the
  // eye) fits: at distance d the tangent cone's half-width on the plane through c is r d / sqrt(d^2 - r^2).
  const float d = length(c);
  const float half_width = orthographic ? r : (d > r * 1.0001 ? r * d / sqrt(d * d - r * r) : 4.0 * r);
  const vec3 to_eye = orthographic ? vec3(0.0, 0.0, 1.0) : -normalize(c);
  const vec3 right = normalize(cross(abs(to_eye.y) < 0.99 ? vec3(0, 1, 0) : vec3(1, 0, 0), to_eye));
  const vec3 up = cross(to_eye, right);
  ray_point = c + (right * corner.x + up * corner.y) * half_width * 1.05;
  centre_radius_view = vec4(c, r);
  sphere_colour = s.colour;
  gl_Position = projection * vec4(ray_point, 1.0);
}
