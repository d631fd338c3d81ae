#include "render/ShadowMaps.hpp"

#include "core/Error.hpp"

#include <epoxy/gl.h>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/type_ptr.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>

namespace kf::render {

ShadowMaps::ShadowMaps(int resolution, int cascades)
    : resolution_(resolution), cascades_(cascades) {
  if (resolution < 16 || cascades < 1 || cascades > kMaxCascades)
    throw Error("render: shadow maps of " + std::to_string(cascades) + " cascades of " +
                std::to_string(resolution) + " texels (1.." + std::to_string(kMaxCascades) +
                " cascades of at least 16)");
  glCreateTextures(GL_TEXTURE_2D_ARRAY, 1, &texture_);
  glTextureStorage3D(texture_, 1, GL_DEPTH_COMPONENT32F, resolution, resolution, cascades);
  glTextureParameteri(texture_, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
  glTextureParameteri(texture_, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glTextureParameteri(texture_, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glTextureParameteri(texture_, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  // A hardware comparison: texture() returns the filtered share of texels nearer than the
  // reference.
  glTextureParameteri(texture_, GL_TEXTURE_COMPARE_MODE, GL_COMPARE_REF_TO_TEXTURE);
  glTextureParameteri(texture_, GL_TEXTURE_COMPARE_FUNC, GL_LEQUAL);
  glCreateFramebuffers(1, &fbo_);
  glNamedFramebufferDrawBuffer(fbo_, GL_NONE);
  glNamedFramebufferReadBuffer(fbo_, GL_NONE);
  views_.resize(std::size_t(cascades));
  split_.assign(std::size_t(cascades), 0);
  texel_.assign(std::size_t(cascades), 0);
  range_.assign(std::size_t(cascades), 1);
  check_gl("making shadow maps");
}

ShadowMaps::~ShadowMaps() {
  glDeleteFramebuffers(1, &fbo_);
  glDeleteTextures(1, &texture_);
}

void ShadowMaps::fit(const Camera& camera, double aspect, const glm::dvec3& lo,
                     const glm::dvec3& hi, const glm::vec3& toward_light) {
  const glm::dmat4 eye_view(camera.view());
  const glm::dmat4 eye_world = glm::inverse(eye_view);
  auto corner = [&](int k) {
    return glm::dvec3(k & 1 ? hi.x : lo.x, k & 2 ? hi.y : lo.y, k & 4 ? hi.z : lo.z);
  };
  // The box's depth range in the camera's view, within its near and far planes.
  double d0 = std::numeric_limits<double>::infinity(), d1 = 0;
  for (int k = 0; k < 8; ++k) {
    const double d = -(eye_view * glm::dvec4(corner(k), 1.0)).z;
    d0 = std::min(d0, d);
    d1 = std::max(d1, d);
  }
  d0 = std::max(d0, camera.near);
  d1 = std::clamp(d1, d0 * (1 + 1e-6), camera.far);
  // The light's view: from outside the box along the light, looking at its centre.
  const glm::dvec3 l = glm::normalize(glm::dvec3(toward_light)), centre = 0.5 * (lo + hi);
  const double radius = std::max(0.5 * glm::length(hi - lo), 1e-9);
  const glm::dvec3 up = std::abs(l.z) < 0.99 ? glm::dvec3(0, 0, 1) : glm::dvec3(0, 1, 0);
  const glm::dmat4 light = glm::lookAt(centre + 2 * radius * l, centre, up);
  glm::dvec3 box_lo(std::numeric_limits<double>::infinity()), box_hi(-box_lo);
  for (int k = 0; k < 8; ++k) {
    const glm::dvec3 p(light * glm::dvec4(corner(k), 1.0));
    box_lo = glm::min(box_lo, p);
    box_hi = glm::max(box_hi, p);
  }
  const double tan_v = std::tan(glm::radians(camera.fov_deg) / 2), tan_h = tan_v * aspect;
  double start = d0;
  for (int c = 0; c < cascades_; ++c) {
    const double f = double(c + 1) / cascades_;
    const double end =
        c + 1 == cascades_ ? d1 : 0.5 * (d0 * std::pow(d1 / d0, f)) + 0.5 * (d0 + (d1 - d0) * f);
    // The slice's 8 corners in the light's view: its x and y bounds, within the box's.
    glm::dvec2 s_lo(std::numeric_limits<double>::infinity()), s_hi(-s_lo);
    for (double d : {start, end})
      for (int k = 0; k < 4; ++k) {
        const glm::dvec4 v((k & 1 ? 1 : -1) * d * tan_h, (k & 2 ? 1 : -1) * d * tan_v, -d, 1.0);
        const glm::dvec3 p(light * (eye_world * v));
        s_lo = glm::min(s_lo, glm::dvec2(p));
        s_hi = glm::max(s_hi, glm::dvec2(p));
      }
    s_lo = glm::max(s_lo, glm::dvec2(box_lo));
    s_hi = glm::min(s_hi, glm::dvec2(box_hi));
    if (!(s_lo.x < s_hi.x && s_lo.y < s_hi.y)) { // the slice misses the box: any small view
      s_lo = glm::dvec2(box_lo);
      s_hi = glm::dvec2(box_hi);
    }
    // Square texels: the larger side sets the size; a texel of margin each way.
    const double side = std::max(s_hi.x - s_lo.x, s_hi.y - s_lo.y);
    const double texel = side / (resolution_ - 2);
    const glm::dvec2 mid = 0.5 * (s_lo + s_hi);
    const double half = 0.5 * side + texel;
    // Depth: every caster in the box, whatever slice it shades.
    const double near = -box_hi.z - texel, far = -box_lo.z + texel;
    const glm::dmat4 proj =
        glm::ortho(mid.x - half, mid.x + half, mid.y - half, mid.y + half, near, far);
    views_[std::size_t(c)] = {glm::mat4(light), glm::mat4(proj), true};
    split_[std::size_t(c)] = end;
    texel_[std::size_t(c)] = 2 * half / resolution_;
    range_[std::size_t(c)] = far - near;
    start = end;
  }
}

void ShadowMaps::begin(int k) {
  glNamedFramebufferTextureLayer(fbo_, GL_DEPTH_ATTACHMENT, texture_, 0, k);
  const GLenum status = glCheckNamedFramebufferStatus(fbo_, GL_FRAMEBUFFER);
  if (status != GL_FRAMEBUFFER_COMPLETE)
    throw Error("render: the shadow map's framebuffer is incomplete (status " +
                std::to_string(status) + ")");
  glBindFramebuffer(GL_FRAMEBUFFER, fbo_);
  glViewport(0, 0, resolution_, resolution_);
  glClearDepth(1.0);
  glClear(GL_DEPTH_BUFFER_BIT);
}

std::vector<float> ShadowMaps::read() const {
  std::vector<float> d(std::size_t(resolution_) * resolution_ * cascades_);
  glGetTextureImage(texture_, 0, GL_DEPTH_COMPONENT, GL_FLOAT, GLsizei(d.size() * sizeof(float)),
                    d.data());
  check_gl("reading the shadow maps");
  return d;
}

void ShadowMaps::write(const std::vector<float>& d) {
  if (d.size() != std::size_t(resolution_) * resolution_ * cascades_)
    throw Error("render: " + std::to_string(d.size()) + " shadow depths for " +
                std::to_string(cascades_) + " maps of " + std::to_string(resolution_) + "^2");
  glTextureSubImage3D(texture_, 0, 0, 0, 0, resolution_, resolution_, cascades_, GL_DEPTH_COMPONENT,
                      GL_FLOAT, d.data());
  check_gl("writing the shadow maps");
}

void ShadowMaps::bind_for_lookup(unsigned p) const {
  glBindTextureUnit(1, texture_);
  glUniform1i(glGetUniformLocation(p, "shadow_map"), 1);
  glUniform1i(glGetUniformLocation(p, "shadow_cascades"), cascades_);
  auto at = [p](const char* name, int k) {
    char full[32];
    std::snprintf(full, sizeof full, "%s[%d]", name, k);
    return glGetUniformLocation(p, full);
  };
  for (int k = 0; k < cascades_; ++k) {
    const auto c = std::size_t(k);
    const glm::mat4 m = views_[c].projection * views_[c].view;
    glUniformMatrix4fv(at("shadow_matrix", k), 1, GL_FALSE, glm::value_ptr(m));
    glUniform1f(at("shadow_split", k), float(split_[c]));
    glUniform1f(at("shadow_texel", k), float(texel_[c]));
    glUniform1f(at("shadow_range", k), float(range_[c]));
  }
}

} // namespace kf::render
