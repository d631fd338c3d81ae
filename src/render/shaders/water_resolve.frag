#version 450 core
// The picture from the opaque scene and the water's layers (render/WaterLayers), a pixel each.
// Where the water's nearest front face lies before the opaque scene, the eye's ray refracts
// there by Snell's law and is followed through the depth images: to the opaque scene behind (its
// colour is what the ray brings), and through the water's nearest back face, where it leaves the
// water (straight on from there: one refraction a pixel). The light is absorbed along the ray's
// path in the water (Beer-Lambert, exp(-absorption L)) and added to the surface's own by its
// share (1 - F). A pixel whose nearest water face is a back face sees from inside the water:
// the opaque scene straight through, absorbed over its distance.
layout(binding = 0) uniform sampler2D opaque_colour;
layout(binding = 1) uniform sampler2D opaque_depth;
layout(binding = 2) uniform sampler2D surface;
layout(binding = 3) uniform sampler2D packed_normal;
layout(binding = 4) uniform sampler2D front_depth;
layout(binding = 5) uniform sampler2D back_depth;
uniform mat4 projection;
uniform mat4 inverse_projection;
uniform vec3 absorption;      // per metre, per channel
uniform float relative_index; // air's over water's (1 / 1.333)
out vec4 frag;

vec2 size() { return vec2(textureSize(opaque_depth, 0)); }
// The view-space point at a window position (pixels) and depth in [0, 1].
vec3 view_at(vec2 window, float depth) {
  const vec4 v = inverse_projection * vec4(2.0 * window / size() - 1.0, 2.0 * depth - 1.0, 1.0);
  return v.xyz / v.w;
}
vec3 window_of(vec3 p) { // pixels and depth
  const vec4 c = projection * vec4(p, 1.0);
  return vec3((0.5 * c.xy / c.w + 0.5) * size(), 0.5 * c.z / c.w + 0.5);
}
bool on_screen(vec3 w) {
  return all(greaterThanEqual(w.xy, vec2(0.0))) && all(lessThan(w.xy, size()));
}
// A depth image between its texels' centres (bilinear): exact on a plane, whose window depth is
// affine in the window's x and y; the nearest texel's would put a slanted floor up to half a
// pixel's depth off (a few percent of the light absorbed on the way, at a grazing view).
float depth_at(sampler2D depth, vec2 w) {
  const vec2 x = w - 0.5;
  const ivec2 i = ivec2(floor(x)), last = textureSize(depth, 0) - 1;
  const vec2 f = x - vec2(i);
  const float d00 = texelFetch(depth, clamp(i, ivec2(0), last), 0).r;
  const float d10 = texelFetch(depth, clamp(i + ivec2(1, 0), ivec2(0), last), 0).r;
  const float d01 = texelFetch(depth, clamp(i + ivec2(0, 1), ivec2(0), last), 0).r;
  const float d11 = texelFetch(depth, clamp(i + ivec2(1, 1), ivec2(0), last), 0).r;
  return mix(mix(d00, d10, f.x), mix(d01, d11, f.x), f.y);
}
// Whether the ray's point p lies behind the depth image's surface where it projects (off the
// screen: past it, the march ends there).
bool behind(sampler2D depth, vec3 p) {
  const vec3 w = window_of(p);
  return !on_screen(w) || w.z > depth_at(depth, w.xy);
}
// The same at the nearest texel (one read, not four): the march's coarse test.
bool behind_texel(sampler2D depth, vec3 p) {
  const vec3 w = window_of(p);
  return !on_screen(w) || w.z > texelFetch(depth, ivec2(w.xy), 0).r;
}
// The ray's length from p along t where it passes behind the image, between a (in front) and b.
float refine(sampler2D depth, vec3 p, vec3 t, float a, float b) {
  for (int i = 0; i < 10; ++i) {
    const float m = 0.5 * (a + b);
    if (behind(depth, p + t * m))
      b = m;
    else
      a = m;
  }
  return b;
}
vec3 decode(vec2 e) {
  vec3 n = vec3(e, 1.0 - abs(e.x) - abs(e.y));
  if (n.z < 0.0)
    n.xy = (1.0 - abs(n.yx)) * vec2(n.x >= 0.0 ? 1.0 : -1.0, n.y >= 0.0 ? 1.0 : -1.0);
  return normalize(n);
}
void main() {
  const ivec2 px = ivec2(gl_FragCoord.xy);
  const vec2 centre = vec2(px) + 0.5;
  const float zo = texelFetch(opaque_depth, px, 0).r;
  const float zf = texelFetch(front_depth, px, 0).r, zb = texelFetch(back_depth, px, 0).r;
  const vec4 seen = texelFetch(opaque_colour, px, 0);
  if (min(zf, zb) >= zo) { // no water before the opaque scene
    frag = seen;
    return;
  }
  if (zb < zf) { // the eye in the water
    frag = vec4(seen.rgb * exp(-absorption * length(view_at(centre, min(zb, zo)))), seen.a);
    return;
  }
  const vec4 s = texelFetch(surface, px, 0);
  const vec3 p = view_at(centre, zf);
  const vec3 v = normalize(p);
  vec3 n = decode(texelFetch(packed_normal, px, 0).xy);
  if (dot(n, v) > 0.0)
    n = -n;
  const vec3 t = refract(v, n, relative_index);
  // March twice as far as the straight ray's way to the opaque scene, in steps tested at the
  // nearest texel, then halve the step that crossed each image (and the next: the texel's and
  // the interpolated depth may place the crossing a step apart) between texel centres.
  // (Before the background, whose depth is the far plane's, the back face's distance sets the
  // scale: the ray leaves a drop within it, and the background is the same wherever it lands.)
  const float reach = 2.0 * distance(p, view_at(centre, zo < 1.0 ? zo : zb));
  const int steps = 48;
  const float step = reach / float(steps);
  float hit = -1.0, leave = -1.0, last = 0.0;
  for (int i = 1; i <= steps && hit < 0.0; ++i) {
    const float d = step * float(i);
    const vec3 q = p + t * d;
    if (leave < 0.0 && behind_texel(back_depth, q))
      leave = refine(back_depth, p, t, last, min(d + step, reach));
    if (behind_texel(opaque_depth, q))
      hit = refine(opaque_depth, p, t, last, min(d + step, reach));
    last = d;
  }
  if (hit < 0.0)
    hit = reach;
  if (leave < 0.0 || leave > hit)
    leave = hit;
  vec3 w = window_of(p + t * hit);
  const ivec2 at = clamp(ivec2(w.xy), ivec2(0), ivec2(size()) - 1);
  const vec3 through = texelFetch(opaque_colour, at, 0).rgb * exp(-absorption * leave);
  frag = vec4(s.rgb + (1.0 - s.a) * through, seen.a);
}
