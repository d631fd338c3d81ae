#version 450 core
// The translucent water's front faces (paper §6.2): what the surface itself sends to the eye,
// the environment (the scene's cube map over the sky) mirrored by Fresnel's share F (Schlick,
// water's F0 = 0.02) and the light's highlight, with F in alpha; and the surface's normal (view
// space, octahedral) for the resolve (water_resolve.frag), which refracts through it and adds
// (1 - F) of what the water lets through. environment.glsl and shadow.glsl are inserted after
// the #version line.
in vec3 view_point;
in vec3 view_normal;
in float vertex_shade;
uniform vec3 light_view;
uniform float specular_strength;
uniform bool reflective; // off: no mirrored environment, all but the highlight let through
layout(location = 0) out vec4 surface;
layout(location = 1) out vec2 packed_normal;
// A unit vector as a point of the octahedron |x| + |y| + |z| = 1 unfolded onto [-1, 1]^2.
vec2 octahedral(vec3 n) {
  n /= abs(n.x) + abs(n.y) + abs(n.z);
  if (n.z < 0.0)
    n.xy = (1.0 - abs(n.yx)) * vec2(n.x >= 0.0 ? 1.0 : -1.0, n.y >= 0.0 ? 1.0 : -1.0);
  return n.xy;
}
void main() {
  const vec3 dir = normalize(view_point);
  vec3 n = normalize(view_normal);
  if (dot(n, dir) > 0.0)
    n = -n;
  const float cos_light = dot(n, light_view);
  const float lit = light_reaching((inverse_view * vec4(view_point, 1.0)).xyz,
                                   mat3(inverse_view) * n, -view_point.z, cos_light);
  const vec3 h = normalize(light_view - dir);
  const float specular = pow(max(dot(n, h), 0.0), 64.0) * specular_strength * lit;
  float f = 0.0;
  vec3 reflected = vec3(0.0);
  if (reflective) {
    f = 0.02 + 0.98 * pow(1.0 - max(dot(n, -dir), 0.0), 5.0);
    reflected = f * mirrored(mat3(inverse_view) * reflect(dir, n));
  }
  surface = vec4(reflected + vec3(specular), f);
  packed_normal = octahedral(n);
}
