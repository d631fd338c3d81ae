// The shadow lookup shared by the lit passes (inserted after their #version line): cascaded
// shadow maps of the one directional light, each cascade an orthographic view along the light
// covering a slice of the camera's depth, filtered over 5 x 5 texels (soft edges).
uniform int shadow_cascades; // 0: no shadows (and the light's own depth pass)
uniform sampler2DArrayShadow shadow_map;
uniform mat4 shadow_matrix[4]; // world -> the cascade's clip space
uniform float shadow_split[4]; // the view distance where cascade k ends
uniform float shadow_texel[4]; // a texel's size in the world
uniform float shadow_range[4]; // the cascade's depth range in the world
uniform mat4 inverse_view;
// The light's share at a surface point (1: lit, 0: shadowed), seen at view_distance, its normal
// at cos_light to the light.
float light_reaching(vec3 world, vec3 world_normal, float view_distance, float cos_light) {
  if (shadow_cascades == 0)
    return 1.0;
  int k = 0;
  while (k + 1 < shadow_cascades && view_distance > shadow_split[k])
    ++k;
  if (cos_light <= 0.0)
    return 0.0; // facing away: its own body shades it
  // No acne: the point moved off the surface by 1.5 texels along its normal, and compared a
  // depth bias nearer the light that covers the filter's reach (2 texels) across the surface's
  // slope to the light (tan, capped where the surface grazes the light).
  const vec4 c = shadow_matrix[k] * vec4(world + world_normal * (1.5 * shadow_texel[k]), 1.0);
  const vec3 q = c.xyz / c.w * 0.5 + 0.5;
  if (any(lessThan(q, vec3(0.0))) || any(greaterThan(q, vec3(1.0))))
    return 1.0;
  const float slope = min(sqrt(max(1.0 - cos_light * cos_light, 0.0)) / cos_light, 10.0);
  const float reference = q.z - (1.0 + 2.5 * slope) * shadow_texel[k] / shadow_range[k];
  const vec2 texel = 1.0 / vec2(textureSize(shadow_map, 0).xy);
  float sum = 0.0;
  for (int i = -2; i <= 2; ++i)
    for (int j = -2; j <= 2; ++j)
      sum += texture(shadow_map, vec4(q.xy + vec2(i, j) * texel, float(k), reference));
  return sum / 25.0;
}
