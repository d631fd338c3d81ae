#version 450 core
// A volumetric yarn's slice shaded from the lumislice (render/Lumislice): the section's point
// turned back by the twist to the texture's frame; its density gives the slice's opacity over
// the path a line of sight crosses to the next slice, 1 - exp(-extinction density path); the
// light reaching it through the yarn's own fibres comes from the texture's layer of the light's
// direction in the section (interpolated between the two nearest), times the shadow maps' share;
// the ambient light scaled by its share that reaches the point (the last layer: the mean over
// the directions).
// The colour darkened where wet (shade); out premultiplied by the opacity (blended "over").
in vec2 section;
in float angle;
in float shade;
in float path;
in vec2 light_in_section;
in float lit;
uniform sampler2DArray lumislice; // 0: density; 1 + k: light from direction k; then ambient
uniform int light_directions;
uniform float extinction; // [1/R]
uniform float ambient;
uniform vec4 colour;
out vec4 frag;

void main() {
  const float c = cos(angle), s = sin(angle);
  const vec2 q = vec2(c * section.x + s * section.y, -s * section.x + c * section.y);
  const vec2 uv = 0.5 * q + 0.5;
  // Every lookup before the discard: a texture's level comes from its coordinates' derivatives
  // across neighbouring fragments, undefined after a fragment of them has been discarded.
  const float d = texture(lumislice, vec3(uv, 0.0)).r;
  const float phi = atan(light_in_section.y, light_in_section.x) - angle;
  const float f = fract(phi / 6.28318530717959) * float(light_directions);
  const int k0 = int(f) % light_directions, k1 = (k0 + 1) % light_directions;
  const float through = mix(texture(lumislice, vec3(uv, float(1 + k0))).r,
                            texture(lumislice, vec3(uv, float(1 + k1))).r, fract(f));
  const float around = texture(lumislice, vec3(uv, float(1 + light_directions))).r;
  const float a = 1.0 - exp(-extinction * d * path);
  if (a < 1.0 / 512.0)
    discard;
  const vec3 body = colour.rgb * shade * (ambient * around + (1.0 - ambient) * through * lit);
  frag = vec4(body * a, a);
}
