#include "render/Lighting.hpp"

#include "core/Error.hpp"

#include <epoxy/gl.h>
#include <glm/gtc/type_ptr.hpp>

#include <cstdio>

namespace kf::render {

void use_lit_program(unsigned p, const Camera& camera, double aspect, const Lighting& light) {
  const glm::mat4 view = camera.view(), proj = camera.projection(aspect);
  const glm::vec3 light_view =
      glm::normalize(glm::vec3(view * glm::vec4(light.toward_light, 0.0f)));
  glUseProgram(p);
  glUniformMatrix4fv(glGetUniformLocation(p, "view"), 1, GL_FALSE, glm::value_ptr(view));
  glUniformMatrix4fv(glGetUniformLocation(p, "projection"), 1, GL_FALSE, glm::value_ptr(proj));
  glUniform3fv(glGetUniformLocation(p, "light_view"), 1, glm::value_ptr(light_view));
  glUniform1f(glGetUniformLocation(p, "ambient"), light.ambient);
  glUniform1f(glGetUniformLocation(p, "specular_strength"), light.specular);
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
