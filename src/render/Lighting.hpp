#pragma once
// The one light of a picture and what every lit pass sets from it (the sphere impostors, the
// meshes): the view's matrices, the light in view space, ambient and highlights, and the shadow
// lookup. Their shaders share the uniforms' names (view, projection, orthographic, light_view,
// ambient, specular_strength, and shadow.glsl's).
#include "render/Camera.hpp"

#include <glm/glm.hpp>

#include <string>

namespace kf::render {

class ShadowMaps;

/// What a pass draws through: the camera's perspective, or a light's orthographic view (parallel
/// rays: the sphere impostors cast them along -z).
struct ViewMatrices {
  glm::mat4 view{1.0f}, projection{1.0f};
  bool orthographic = false;
  static ViewMatrices of(const Camera& camera, double aspect) {
    return {camera.view(), camera.projection(aspect), false};
  }
};

/// One directional light: ambient + diffuse scale the surface's colour (its albedo, which the
/// wet knit's darkening scales), a white Blinn-Phong highlight adds the light's own colour; both
/// only in the share of the light that reaches the point (shadows, where given).
struct Lighting {
  glm::vec3 toward_light{0.4f, -0.5f, 0.75f}; // world space, need not be unit
  float ambient = 0.25f;
  float specular = 0.25f;              // 0: no highlights
  const ShadowMaps* shadows = nullptr; // null: every point lit
};

/// Uses `program` and sets its view, light and shadow uniforms.
void use_lit_program(unsigned program, const ViewMatrices& view, const Lighting& light);

/// A lit shader's source with the shadow lookup (shaders/shadow.glsl) and the environment a
/// reflection sees (shaders/environment.glsl) after its #version line.
std::string with_light_lookups(const char* source);

/// A kf::Error naming `what` if GL reports an error since the last check.
void check_gl(const std::string& what);

} // namespace kf::render
