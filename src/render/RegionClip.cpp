#include "render/RegionClip.hpp"

#include "render/ShaderProgram.hpp"
#include "render/Shaders.hpp"

#include <epoxy/gl.h>

#include <algorithm>
#include <limits>

namespace kf::render {

std::string with_region_clip(const char* source) {
  return with_after_version(source, shaders::kRegionClipGlsl);
}

void clip_to(unsigned program, const Region* region) {
  for (int i = 0; i < 6; ++i) {
    if (region)
      glEnable(GLenum(GL_CLIP_DISTANCE0 + i));
    else
      glDisable(GLenum(GL_CLIP_DISTANCE0 + i));
  }
  // A k-d split's outer faces lie at infinity; a float's range is far enough. Without a
  // region, all of space (the distances are ignored then, but not by every driver).
  const double inf = std::numeric_limits<double>::infinity();
  const Region all{glm::dvec3(-inf), glm::dvec3(inf)}, &r = region ? *region : all;
  const auto f = [](double v) { return float(std::clamp(v, -1e30, 1e30)); };
  glProgramUniform3f(program, glGetUniformLocation(program, "clip_lo"), f(r.lo.x), f(r.lo.y),
                     f(r.lo.z));
  glProgramUniform3f(program, glGetUniformLocation(program, "clip_hi"), f(r.hi.x), f(r.hi.y),
                     f(r.hi.z));
}

} // namespace kf::render
