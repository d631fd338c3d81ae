#pragma once
// The lumislice (Xu et al. 2001; paper §6): a yarn's cross-section as a texture, computed once
// from the yarn's structure (plies of fibres, the fuzz of loose fibres about them), then drawn on
// the quads of the volumetric yarns (VolumeYarns) rotating with the yarn's twist. Two things a
// texel: the fibres' density (their coverage of it) and, for a ring of light directions in the
// section's plane, the light that reaches it through the fibres between it and the light
// (self-shadowing: a yarn's far side is dark). And the section seen whole: for lines of sight
// in the section's plane, what the whole section sends along each (its opacity and light), for
// a yarn drawn as one quad where it is small on screen.
#include <cstdint>
#include <vector>

namespace kf::render {

/// A yarn's structure, lengths in its radius R (the plies reach R, the fuzz beyond).
struct LumisliceSpec {
  int texels = 64;            // a side of the texture, which spans [-reach, reach]^2
  int plies = 3;              // twisted strands of fibres
  double ply_radius = 0.5;    // a ply's
  double ply_offset = 0.5;    // its centre's distance from the yarn's axis
  int fibres_per_ply = 60;    // fibres in a ply's section
  double fibre_radius = 0.05; // a fibre's
  int fuzz = 15;              // loose fibres about the plies
  double fuzz_reach = 0.4;    // how far past R they reach: reach = 1 + fuzz_reach
  double extinction = 6.0;    // light's attenuation [1/R] through density 1
  int light_directions = 8;   // toward the light at angles 2 pi k / light_directions
  std::uint32_t seed = 1;     // the fibres' places
  double twist_pitch = 8.0;   // the plies turn once in this length [R] along the yarn
  int view_angles = 256;      // lines of sight seen whole at angles 2 pi a / view_angles
  double reach() const { return 1 + fuzz_reach; }
};

/// The texture: texel (i, j) (i along x, row j along y) covers x in [-reach + i h, -reach + (i
/// + 1) h), h = 2 reach / texels, likewise y.
struct Lumislice {
  LumisliceSpec spec;
  std::vector<float> density; // texels^2, the share of the texel the fibres cover, in [0, 1]
  std::vector<float> light;   // light_directions x texels^2: the light reaching the texel
  // texels^2: the mean of light over the directions, the share of a surrounding (ambient) light
  // that reaches the texel: dark among the plies, bright in the fuzz
  std::vector<float> ambient;
  // The section seen whole: for a line of sight at angle phi_a = 2 pi a / view_angles (along
  // (cos, sin)) at offset x_i (texel i's centre; along (-sin, cos)), index a texels + i: its
  // opacity through the section, and the light it carries to the eye (premultiplied, colour
  // aside): of the ambient light, and (light_directions x that) of the light from direction k;
  // front to back "over" of steps of half a texel.
  std::vector<float> seen_alpha, seen_ambient, seen_light;
  // The fibres' sections: centre and radius [R], the plies' first, then the fuzz.
  std::vector<float> fibre_x, fibre_y, fibre_r;
  float texel_size() const { return float(2 * spec.reach() / spec.texels); }
  /// A field of the texture (density, ambient, a light layer) at a point [R]: bilinear between
  /// texel centres, `outside` beyond them.
  float at(const float* field, float x, float y, float outside = 0) const;
  float density_at(float x, float y) const { return at(density.data(), x, y); }
};

/// Places the fibres (seeded: the same texture every run) and computes both fields: the density
/// as the covered share of 4 x 4 samples a texel; the light as exp(-extinction x the density's
/// integral toward the light), marched in steps of half a texel; the section seen whole from
/// both. A kf::Error names a spec that cannot make a yarn (no plies, radii <= 0, fewer than 8
/// texels, fewer than 1 direction or view angle).
Lumislice make_lumislice(const LumisliceSpec& spec);

} // namespace kf::render
