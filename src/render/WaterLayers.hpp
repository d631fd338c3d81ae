#pragma once
// The fluid's surface as translucent water (paper §6.2; DESIGN §8): the surface mirrors its
// environment by Fresnel's share and lets the rest through, refracted by Snell's law at the
// surface and absorbed on its way through the water (Beer-Lambert). Deferred, in two steps:
// the water's faces are drawn into layers (the nearest front face's own light, normal and depth;
// the nearest back face's depth), then a full-screen pass (the resolve) follows each pixel's
// refracted ray through the depth images of the opaque scene and of the back faces. A layer is
// the nearest of its kind at a pixel, so sort-last parts composite by depth alone (LayeredPixel)
// and the resolve of their composite is the whole frame's picture.
#include "render/DepthComposite.hpp"
#include "render/Lighting.hpp"
#include "render/OffscreenTarget.hpp"
#include "render/ShaderProgram.hpp"

#include <glm/glm.hpp>

#include <memory>
#include <vector>

namespace kf::render {

/// How light passes through the water: refracted (the index relative to air) and absorbed, a
/// rate a metre for each channel.
struct WaterOptics {
  float refractive_index = 1.333f;
  glm::vec3 absorption{0.0f};
};

/// The absorption a metre that lets `tint` of each channel through `depth` metres of water:
/// -ln(tint) / depth (a channel's tint at least 1e-3).
glm::vec3 absorption_for(const glm::vec3& tint, double depth);

class WaterLayers {
public:
  /// Needs a current context.
  WaterLayers(int width, int height);
  ~WaterLayers();
  WaterLayers(const WaterLayers&) = delete;
  WaterLayers& operator=(const WaterLayers&) = delete;

  /// Draws go to the front layers from now on, cleared (depth 1, no light): the caller draws
  /// the water's front faces (MeshLook::water = Water::Front).
  void begin_front();
  /// Draws go to the back faces' depth, cleared (Water::Back).
  void begin_back();
  /// The picture into `out` (bound and drawn over): `opaque`'s colour and depth seen through
  /// the layers, from `view` (a perspective camera's).
  void resolve(const OffscreenTarget& opaque, const ViewMatrices& view, const WaterOptics& optics,
               OffscreenTarget& out);
  /// The opaque scene's colour and depth (`opaque`'s) and the water's layers, a record a pixel,
  /// in GL's row order (the bottom row first: a composite needs only the same order on every
  /// rank, and the host flips nothing); and all of them replaced by such (a composite's).
  std::vector<LayeredPixel> read(const OffscreenTarget& opaque) const;
  void write(const std::vector<LayeredPixel>& layers, OffscreenTarget& opaque);

private:
  int width_, height_;
  unsigned front_fbo_ = 0, back_fbo_ = 0, surface_ = 0, normal_ = 0, front_ = 0, back_ = 0,
           vao_ = 0;
  std::unique_ptr<ShaderProgram> resolve_;
};

} // namespace kf::render
