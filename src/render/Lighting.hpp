#pragma once
// The one light of a picture and what every lit pass sets from it (the sphere impostors, the
// fluid's mesh): the camera's matrices, the light in view space, ambient and highlights. Their
// shaders share the uniforms' names (view, projection, light_view, ambient, specular_strength).
#include "render/Camera.hpp"

#include <glm/glm.hpp>

#include <string>

namespace kf::render {

/// One directional light: ambient + diffuse scale the surface's colour (its albedo, which the
/// wet knit's darkening scales), a white Blinn-Phong highlight adds the light's own colour.
struct Lighting {
  glm::vec3 toward_light{0.4f, -0.5f, 0.75f}; // world space, need not be unit
  float ambient = 0.25f;
  float specular = 0.25f; // 0: no highlights
};

/// Uses `program` and sets its camera and light uniforms.
void use_lit_program(unsigned program, const Camera& camera, double aspect, const Lighting& light);

/// A kf::Error naming `what` if GL reports an error since the last check.
void check_gl(const std::string& what);

} // namespace kf::render
