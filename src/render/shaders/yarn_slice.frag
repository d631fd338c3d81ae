#version 450 core
// A volumetric yarn's slice shaded from the lumislice (render/Lumislice): the section's point
// turned back by the twist to the texture's frame; its density gives the slice's opacity over
// the path a line of sight crosses to the next slice, 1 - exp(-extinction density path); the
// light reaching it through the yarn's own fibres comes from the texture's layer of the light's
// direction in the section (interpolated between the two nearest), times the shadow maps' share;
// the ambient light scaled by its share that reaches the point (the last layer: the mean over
// the directions).
// The colour darkened where wet (shade); out premultiplied by the opacity (blended "over").
// A quad seen whole (the yarn small on screen) is shaded from the section seen whole along the
// line of sight (Lumislice's seen_*: the offset x, the line's angle in the texture's frame),
// its opacity raised for a line oblique to the section (1 - (1 - a)^(1 / sin)).
in vec2 section;
in float angle;
in float shade;
in float path;
in vec2 light_in_section;
in float lit;
in vec2 view_in_section;
flat in int whole;
in vec4 stitch_colour;
uniform sampler2DArray lumislice; // 0: density; 1 + k: light from direction k; then ambient
uniform sampler2DArray seen_whole; // 0: opacity; 1: ambient light; 2 + k: from direction k
uniform int light_directions;
uniform int view_angles;
uniform float extinction; // [1/R]
uniform float ambient;
uniform vec4 colour;
out vec4 frag;

void main() {
  const float c = cos(angle), s = sin(angle);
  const vec2 q = vec2(c * section.x + s * section.y, -s * section.x + c * section.y);
  const vec2 uv = 0.5 * q + 0.5;
  // Seen whole: the line of sight's offset from the axis (the section's point across its
  // direction) and its angle in turns (periodic), the table's first angle at its texels' centre.
  const vec2 w = normalize(view_in_section);
  const float turns = (atan(w.y, w.x) - angle) / 6.28318530717959 + 0.5 / float(view_angles);
  const vec2 seen = vec2(0.5 * (section.y * w.x - section.x * w.y) + 0.5, turns);
  // The derivatives (a texture's level) taken here, where every fragment of the quad runs: the
  // lookups below sit in a branch and after a discard. Seen whole, the level follows the
  // offset's alone: along a small yarn the twist sweeps tens of angles a pixel, and a level
  // set by them would average the offsets (the yarn's profile) away with them.
  const vec2 uv_x = dFdx(uv), uv_y = dFdy(uv);
  const vec2 seen_x = vec2(dFdx(seen.x), 0.0), seen_y = vec2(dFdy(seen.x), 0.0);
  const float phi = atan(light_in_section.y, light_in_section.x) - angle;
  const float f = fract(phi / 6.28318530717959) * float(light_directions);
  const int k0 = int(f) % light_directions, k1 = (k0 + 1) % light_directions;
  float a, around, through;
  if (whole == 1) {
    const float a0 = textureGrad(seen_whole, vec3(seen, 0.0), seen_x, seen_y).r;
    const float sine = max(length(view_in_section), 0.2);
    a = 1.0 - pow(1.0 - min(a0, 0.999), 1.0 / sine);
    const float scale = a0 > 0.0 ? a / a0 : 0.0;
    around = scale * textureGrad(seen_whole, vec3(seen, 1.0), seen_x, seen_y).r;
    through = scale * mix(textureGrad(seen_whole, vec3(seen, float(2 + k0)), seen_x, seen_y).r,
                          textureGrad(seen_whole, vec3(seen, float(2 + k1)), seen_x, seen_y).r,
                          fract(f));
  } else {
    const float d = textureGrad(lumislice, vec3(uv, 0.0), uv_x, uv_y).r;
    a = 1.0 - exp(-extinction * d * path);
    // Premultiplied by the slice's opacity like the texture's seen-whole light.
    around = a * textureGrad(lumislice, vec3(uv, float(1 + light_directions)), uv_x, uv_y).r;
    through = a * mix(textureGrad(lumislice, vec3(uv, float(1 + k0)), uv_x, uv_y).r,
                      textureGrad(lumislice, vec3(uv, float(1 + k1)), uv_x, uv_y).r, fract(f));
  }
  if (a < 1.0 / 512.0)
    discard;
  const vec3 base = stitch_colour.a > 0.5 ? stitch_colour.rgb : colour.rgb;
  frag = vec4(base * shade * (ambient * around + (1.0 - ambient) * through * lit), a);
}
