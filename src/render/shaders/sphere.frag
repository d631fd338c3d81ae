#version 450 core
// The ray from the eye (the origin of view space; orthographic: along -z through the quad's
// point) against the sphere: the nearer hit gives the depth and the normal; a miss draws nothing.
in vec3 ray_point;
flat in vec4 centre_radius_view;
flat in vec4 sphere_colour;
uniform mat4 projection;
uniform bool orthographic;
uniform vec3 light_view; // unit vector toward the light, in view space
uniform float ambient;
uniform float specular_strength;
out vec4 frag;
void main() {
  const vec3 c = centre_radius_view.xyz;
  const float r = centre_radius_view.w;
  vec3 hit, dir;
  if (orthographic) {
    const vec2 off = ray_point.xy - c.xy;
    const float h2 = r * r - dot(off, off);
    if (h2 < 0.0)
      discard;
    hit = vec3(ray_point.xy, c.z + sqrt(h2));
    dir = vec3(0.0, 0.0, -1.0);
  } else {
    dir = normalize(ray_point);
    const float b = dot(dir, c);
    const float disc = b * b - (dot(c, c) - r * r);
    if (disc < 0.0)
      discard;
    const float t = b - sqrt(disc);
    if (t <= 0.0)
      discard; // the eye is inside or past it
    hit = dir * t;
  }
  const vec3 n = (hit - c) / r;
  const vec4 clip = projection * vec4(hit, 1.0);
  gl_FragDepth = 0.5 * (clip.z / clip.w) + 0.5;
  const float cos_light = dot(n, light_view);
  const float lit =
      light_reaching((inverse_view * vec4(hit, 1.0)).xyz, mat3(inverse_view) * n, -hit.z, cos_light);
  const float diffuse = max(cos_light, 0.0) * lit;
  const vec3 h = normalize(light_view - dir);
  const float specular = pow(max(dot(n, h), 0.0), 48.0) * specular_strength * lit;
  frag = vec4(sphere_colour.rgb * (ambient + (1.0 - ambient) * diffuse) + vec3(specular),
              sphere_colour.a);
}
