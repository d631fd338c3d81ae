#include "render/Lighting.hpp"

#include "core/Error.hpp"
#include "render/ShaderProgram.hpp"
#include "render/Shaders.hpp"
#include "render/ShadowMaps.hpp"

#include <epoxy/gl.h>
#include <glm/gtc/type_ptr.hpp>

#include <cstdio>
#include <string_view>

namespace kf::render {

void use_lit_program(unsigned p, const ViewMatrices& vm, const Lighting& light) {
  const glm::vec3 light_view =
      glm::normalize(glm::vec3(vm.view * glm::vec4(light.toward_light, 0.0f)));
  const glm::mat4 inverse_view = glm::inverse(vm.view);
  glUseProgram(p);
  glUniformMatrix4fv(glGetUniformLocation(p, "view"), 1, GL_FALSE, glm::value_ptr(vm.view));
  glUniformMatrix4fv(glGetUniformLocation(p, "projection"), 1, GL_FALSE,
                     glm::value_ptr(vm.projection));
  glUniformMatrix4fv(glGetUniformLocation(p, "inverse_view"), 1, GL_FALSE,
                     glm::value_ptr(inverse_view));
  glUniform1i(glGetUniformLocation(p, "orthographic"), vm.orthographic ? 1 : 0);
  glUniform3fv(glGetUniformLocation(p, "light_view"), 1, glm::value_ptr(light_view));
  glUniform1f(glGetUniformLocation(p, "ambient"), light.ambient);
  glUniform1f(glGetUniformLocation(p, "specular_strength"), light.specular);
  // The environment map's sampler on a unit of its own (a cube sampler sharing the shadow
  // maps' unit would make every draw invalid); off until a reflective draw binds one.
  glUniform1i(glGetUniformLocation(p, "scene_environment"), 7);
  glUniform1i(glGetUniformLocation(p, "scene_reflected"), 0);
  if (light.shadows)
    light.shadows->bind_for_lookup(p);
  else
    glUniform1i(glGetUniformLocation(p, "shadow_cascades"), 0);
}

std::string with_light_lookups(const char* source) {
  return with_after_version(with_after_version(source, shaders::kEnvironmentGlsl).c_str(),
                            shaders::kShadowGlsl);
}

void check_gl(const std::string& what) {
  const GLenum err = glGetError();
  if (err == GL_NO_ERROR)
    return;
  char code[16];
  std::snprintf(code, sizeof code, "%04x", err);
  throw Error("render: " + what + " failed (GL error 0x" + code + ")");
}

} // namespace kf::render
