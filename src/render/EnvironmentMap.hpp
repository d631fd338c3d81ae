#pragma once
// What the water mirrors (paper §6.2; DESIGN §8): a cube map of the scene without the fluid,
// drawn from one point (the fluid's centre) into six square faces of 90 degrees. Texels where
// nothing was drawn keep alpha 0, and the reflection there falls back to the sky
// (shaders/environment.glsl), so a faraway sky and the nearby scene mix by coverage.
#include "render/Lighting.hpp"

#include <glm/glm.hpp>

#include <cstdint>
#include <functional>
#include <vector>

namespace kf::render {

class EnvironmentMap {
public:
  /// Texels a face's side; needs a current context.
  explicit EnvironmentMap(int size);
  ~EnvironmentMap();
  EnvironmentMap(const EnvironmentMap&) = delete;
  EnvironmentMap& operator=(const EnvironmentMap&) = delete;

  /// The view through face k (GL's order: +x, -x, +y, -y, +z, -z) from `centre`: a 90-degree
  /// square perspective turned as GL's cube map table (OpenGL 4.5, table 8.19) reads it back.
  static ViewMatrices face_view(int k, const glm::dvec3& centre, double near, double far);
  /// Draws the six faces, cleared to nothing (alpha 0): `draw` draws the scene through the view
  /// it is given (into the bound target, depth tested).
  void render(const glm::dvec3& centre, double near, double far,
              const std::function<void(const ViewMatrices&)>& draw);
  /// The cube map texture (RGBA8, linearly filtered).
  unsigned texture() const { return cube_; }
  int size() const { return size_; }
  /// Face k's texels, 4 bytes each, as GL stores them (row 0 at t = 0).
  std::vector<std::uint8_t> read_face(int k) const;

private:
  int size_;
  unsigned cube_ = 0, depth_ = 0, fbo_ = 0;
};

} // namespace kf::render
