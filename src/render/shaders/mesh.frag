#version 450 core
// The same light as the spheres' (sphere.frag): ambient and diffuse scale the colour, a white
// Blinn-Phong highlight adds the light's. Both faces lit (a surface seen from inside the fluid).
in vec3 view_point;
in vec3 view_normal;
in float vertex_shade;
uniform vec3 light_view;
uniform float ambient;
uniform float specular_strength;
uniform vec4 colour;
out vec4 frag;
void main() {
  const vec3 dir = normalize(view_point);
  vec3 n = normalize(view_normal);
  if (dot(n, dir) > 0.0)
    n = -n;
  const float diffuse = max(dot(n, light_view), 0.0);
  const vec3 h = normalize(light_view - dir);
  const float specular = pow(max(dot(n, h), 0.0), 64.0) * specular_strength;
  frag = vec4(colour.rgb * vertex_shade * (ambient + (1.0 - ambient) * diffuse) + vec3(specular), colour.a);
}
