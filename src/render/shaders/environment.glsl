// The environment a reflected ray sees (world directions, z up; inserted after a #version line):
// a sky brighter toward the horizon over a grey ground.
vec3 environment(vec3 d) {
  if (d.z < 0.0)
    return vec3(0.55, 0.55, 0.53);
  return mix(vec3(0.86, 0.89, 0.93), vec3(0.42, 0.58, 0.85), smoothstep(0.0, 0.6, d.z));
}
// The scene without the fluid as seen from the fluid's centre (render/EnvironmentMap: texture
// unit 7), where it was drawn; the sky where not (alpha 0: its texels hold colour x coverage).
uniform samplerCube scene_environment;
uniform bool scene_reflected;
vec3 mirrored(vec3 d) {
  const vec3 sky = environment(d);
  if (!scene_reflected)
    return sky;
  const vec4 e = texture(scene_environment, d);
  return e.rgb + (1.0 - e.a) * sky;
}
