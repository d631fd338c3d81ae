// The environment a reflected ray sees (world directions, z up; inserted after a #version line):
// a sky brighter toward the horizon over a grey ground.
vec3 environment(vec3 d) {
  if (d.z < 0.0)
    return vec3(0.55, 0.55, 0.53);
  return mix(vec3(0.86, 0.89, 0.93), vec3(0.42, 0.58, 0.85), smoothstep(0.0, 0.6, d.z));
}
