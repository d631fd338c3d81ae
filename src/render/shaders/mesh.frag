#version 450 core
// The same light as the spheres' (sphere.frag): ambient and diffuse scale the colour, a white
// Blinn-Phong highlight adds the light's; both in the light's share that reaches the point (the
// shadows). Both faces lit (a surface seen from inside the fluid).
in vec3 view_point;
in vec3 view_normal;
in float vertex_shade;
in vec4 vertex_colour; // a yarn point's stitch colour where a > 0 (tube.vert), else `colour`
uniform vec3 light_view;
uniform float ambient;
uniform float specular_strength;
uniform vec4 colour;
uniform bool reflective; // water: the sky and the ground mirrored, by Fresnel's share
out vec4 frag;
void main() {
  const vec3 dir = normalize(view_point);
  vec3 n = normalize(view_normal);
  if (dot(n, dir) > 0.0)
    n = -n;
  const float cos_light = dot(n, light_view);
  const float lit = light_reaching((inverse_view * vec4(view_point, 1.0)).xyz,
                                   mat3(inverse_view) * n, -view_point.z, cos_light);
  const float diffuse = max(cos_light, 0.0) * lit;
  const vec3 h = normalize(light_view - dir);
  const float specular = pow(max(dot(n, h), 0.0), 64.0) * specular_strength * lit;
  const vec3 base = vertex_colour.a > 0.5 ? vertex_colour.rgb : colour.rgb;
  vec3 body = base * vertex_shade * (ambient + (1.0 - ambient) * diffuse);
  if (reflective) { // Schlick's Fresnel, water's F0 = 0.02
    const float f = 0.02 + 0.98 * pow(1.0 - max(dot(n, -dir), 0.0), 5.0);
    body = mix(body, mirrored(mat3(inverse_view) * reflect(dir, n)), f);
  }
  frag = vec4(body + vec3(specular), colour.a);
}
