#pragma once
// Cascaded shadow maps of the one directional light (P6): the camera's view of the frame cut in
// depth into slices (the practical split: half logarithmic, half uniform), each covered by an
// orthographic view along the light that holds every caster of the frame's box; the casters'
// depths drawn into one layer each of a depth-texture array, looked up with a 5 x 5 filter by
// the lit passes (shaders/shadow.glsl). Nearer slices are smaller, so their texels are finer
// where the camera looks closely.
#include "render/Camera.hpp"
#include "render/Lighting.hpp"

#include <glm/glm.hpp>

#include <vector>

namespace kf::render {

class ShadowMaps {
public:
  static constexpr int kMaxCascades = 4; // shadow.glsl's arrays
  /// Needs a current context. `resolution` texels a side a cascade, 1..kMaxCascades cascades.
  explicit ShadowMaps(int resolution = 2048, int cascades = 3);
  ~ShadowMaps();
  ShadowMaps(const ShadowMaps&) = delete;
  ShadowMaps& operator=(const ShadowMaps&) = delete;

  /// Fits the cascades to `camera`'s view of the box [lo, hi] (every caster and receiver lies in
  /// it) lit from `toward_light`.
  void fit(const Camera& camera, double aspect, const glm::dvec3& lo, const glm::dvec3& hi,
           const glm::vec3& toward_light);
  int cascades() const { return cascades_; }
  int resolution() const { return resolution_; }
  /// Cascade k's view along the light (orthographic).
  ViewMatrices light_view(int k) const { return views_[std::size_t(k)]; }
  /// The view distance where cascade k ends (the last: the box's far side).
  double split(int k) const { return split_[std::size_t(k)]; }
  /// A texel's size in the world in cascade k.
  double texel(int k) const { return texel_[std::size_t(k)]; }

  /// Draws go into cascade k's layer (depth only, cleared to the far plane) from now on.
  void begin(int k);
  /// Every layer's depths (resolution^2 a layer, layer after layer), and back: ranks that each
  /// drew a part of the casters keep the nearest of all (the minimum) before the lookup.
  std::vector<float> read() const;
  void write(const std::vector<float>& depths);

  /// Binds the maps to texture unit 1 and sets shadow.glsl's uniforms of the program in use.
  void bind_for_lookup(unsigned program) const;

private:
  int resolution_, cascades_;
  unsigned texture_ = 0, fbo_ = 0;
  std::vector<ViewMatrices> views_;
  std::vector<double> split_, texel_, range_;
};

} // namespace kf::render
