#include "render/VolumeYarns.hpp"

#include "core/Error.hpp"
#include "render/GlBuffers.hpp"
#include "render/RegionClip.hpp"
#include "render/Shaders.hpp"
#include "render/TubeRenderer.hpp"
#include "render/YarnTubes.hpp"

#include <epoxy/gl.h>
#include <glm/gtc/type_ptr.hpp>

#include <algorithm>
#include <bit>
#include <cmath>
#include <initializer_list>
#include <string>

namespace kf::render {

namespace {

/// A mipmapped 2D texture array of 8-bit layers w x h, `fields` laid one after another (each a
/// whole number of layers), values in [0, 1]; t repeats (periodic) or is clamped. Mipmapped: a
/// yarn is often a few pixels wide, its fibres far under a pixel; the levels average them (their
/// coverage, the light through them) instead of aliasing into noise.
unsigned byte_layers(int w, int h, int layers,
                     std::initializer_list<const std::vector<float>*> fields, bool periodic_t) {
  std::vector<std::uint8_t> texels;
  texels.reserve(std::size_t(layers) * w * h);
  for (const std::vector<float>* f : fields)
    for (float v : *f)
      texels.push_back(std::uint8_t(std::lround(255 * std::clamp(v, 0.0f, 1.0f))));
  if (texels.size() != std::size_t(layers) * w * h)
    throw Error("render: the lumislice's layers do not fill " + std::to_string(layers) + " x " +
                std::to_string(w) + " x " + std::to_string(h) + " texels");
  unsigned t = 0;
  glCreateTextures(GL_TEXTURE_2D_ARRAY, 1, &t);
  const int levels = 1 + int(std::floor(std::log2(double(std::max(w, h)))));
  glTextureStorage3D(t, levels, GL_R8, w, h, layers);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  glTextureSubImage3D(t, 0, 0, 0, 0, w, h, layers, GL_RED, GL_UNSIGNED_BYTE, texels.data());
  glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  glGenerateTextureMipmap(t);
  glTextureParameteri(t, GL_TEXTURE_MIN_FILTER, GL_LINEAR_MIPMAP_LINEAR);
  glTextureParameteri(t, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glTextureParameteri(t, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glTextureParameteri(t, GL_TEXTURE_WRAP_T, periodic_t ? GL_REPEAT : GL_CLAMP_TO_EDGE);
  return t;
}

} // namespace

VolumeYarns::VolumeYarns(const LumisliceSpec& spec, bool sort_on_cuda, int slices,
                         double detail_pixels)
    : slice_(make_lumislice(spec)), slices_(slices), detail_pixels_(detail_pixels),
      program_("yarn_slice.vert + yarn_slice.frag", with_region_clip(shaders::kYarnSliceVert),
               shaders::kYarnSliceFrag),
      order_program_(
          ShaderProgram::compute("yarn_slices.comp", with_light_lookups(shaders::kYarnSlicesComp))),
      sort_(sort_on_cuda) {
  if (slices < 1 || slices > 4)
    throw Error("render: a volumetric yarn takes 1 to 4 slices a segment, not " +
                std::to_string(slices));
  // The lumislice as a texture array of 8-bit layers: the density, the light a direction, the
  // ambient light's share; and the section seen whole (offset along s, view angle along t,
  // periodic): its opacity, the ambient light's and each direction's light.
  const int n = spec.texels, layers = 2 + spec.light_directions, angles = spec.view_angles;
  texture_ = byte_layers(n, n, layers, {&slice_.density, &slice_.light, &slice_.ambient}, false);
  seen_texture_ = byte_layers(n, angles, layers,
                              {&slice_.seen_alpha, &slice_.seen_ambient, &slice_.seen_light}, true);
  glCreateVertexArrays(1, &vao_); // no attributes: the vertex shader pulls its data
  // {count, instances, first, base instance}: the count added by the compute pass.
  const GLuint command[4] = {0, 1, 0, 0};
  glCreateBuffers(1, &draw_);
  glNamedBufferStorage(draw_, sizeof command, command, GL_DYNAMIC_STORAGE_BIT);
  check_gl("the lumislice's texture (" + std::to_string(n) + "^2 x " + std::to_string(layers) +
           ")");
}

VolumeYarns::~VolumeYarns() {
  glDeleteBuffers(4, buffers_);
  glDeleteBuffers(1, &draw_);
  glDeleteTextures(1, &texture_);
  glDeleteTextures(1, &seen_texture_);
  glDeleteVertexArrays(1, &vao_);
}

void VolumeYarns::bind(const TubeRenderer& tubes) const {
  for (GLuint i = 0; i < 4; ++i) {
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, i, tubes.frame_buffer(int(i)));
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 8 + i, buffers_[i]);
  }
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 12, draw_);
  if (const unsigned colours = tubes.colour_buffer())
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 13, colours);
}

void VolumeYarns::order(const TubeRenderer& tubes, const ViewMatrices& view, double radius,
                        const Lighting& light, int height) {
  const std::size_t segments = tubes.segments();
  slots_ = segments * std::size_t(slices_);
  const GLuint zero = 0;
  glNamedBufferSubData(draw_, 0, sizeof zero, &zero);
  if (slots_ == 0)
    return;
  if (slots_ >= (std::size_t(1) << 32) || segments >= (std::size_t(1) << 28))
    throw Error("render: " + std::to_string(segments) + " yarn segments exceed the slices' codes");
  twist_ = float(2 * M_PI / (slice_.spec.twist_pitch * radius));
  const std::size_t bytes[4] = {slots_ * sizeof(std::uint32_t), slots_ * sizeof(std::uint32_t),
                                slots_ * 2 * sizeof(std::uint32_t), segments * sizeof(float)};
  for (int i = 0; i < 4; ++i)
    buffers_[i] = grown_buffer(buffers_[i], capacity_[i], bytes[i], 1.2);
  bind(tubes);
  const unsigned p = order_program_.id();
  use_lit_program(p, view, light); // the shadow maps' uniforms and sampler
  const glm::vec3 toward = glm::normalize(light.toward_light);
  glProgramUniform3fv(p, glGetUniformLocation(p, "toward_light"), 1, glm::value_ptr(toward));
  const glm::vec3 eye(glm::inverse(view.view)[3]);
  // Pixels a metre at a metre from the eye: the projection's vertical scale over half a picture.
  const bool detail = detail_pixels_ > 0 && height > 0;
  const float pixel_scale = detail ? 0.5f * float(height) * view.projection[1][1] : 0.0f;
  const GLuint group = detail ? GLuint(kYarnGroup) : 1; // yarn_chains keeps a part's groups whole
  glProgramUniform1ui(p, glGetUniformLocation(p, "segments"), GLuint(segments));
  glProgramUniform1ui(p, glGetUniformLocation(p, "slices"), GLuint(slices_));
  glProgramUniform3fv(p, glGetUniformLocation(p, "eye"), 1, glm::value_ptr(eye));
  glProgramUniform1f(p, glGetUniformLocation(p, "reach"), float(slice_.spec.reach()));
  glProgramUniform1f(p, glGetUniformLocation(p, "pixel_scale"), pixel_scale);
  glProgramUniform1f(p, glGetUniformLocation(p, "detail_pixels"), float(detail_pixels_));
  glProgramUniform1ui(p, glGetUniformLocation(p, "group"), group);
  glUseProgram(p);
  const std::size_t threads = (segments + group - 1) / group;
  glDispatchCompute(GLuint((threads + 63) / 64), 1, 1);
  glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT | GL_BUFFER_UPDATE_BARRIER_BIT |
                  GL_COMMAND_BARRIER_BIT);
  check_gl("keying " + std::to_string(slots_) + " yarn slices");
  sort_.sort(buffers_[0], buffers_[1], slots_);
}

void VolumeYarns::draw(const TubeRenderer& tubes, const glm::vec4& colour, const ViewMatrices& view,
                       const Lighting& light, const Region* clip) {
  if (slots_ == 0 || tubes.segments() * std::size_t(slices_) != slots_)
    return;
  const unsigned p = program_.id();
  use_lit_program(p, view, light);
  const glm::vec3 toward = glm::normalize(light.toward_light);
  glUniform3fv(glGetUniformLocation(p, "toward_light"), 1, glm::value_ptr(toward));
  glUniform1ui(glGetUniformLocation(p, "slices"), GLuint(slices_));
  glUniform1f(glGetUniformLocation(p, "reach"), float(slice_.spec.reach()));
  glUniform1f(glGetUniformLocation(p, "twist"), twist_);
  glUniform1i(glGetUniformLocation(p, "light_directions"), slice_.spec.light_directions);
  glUniform1i(glGetUniformLocation(p, "view_angles"), slice_.spec.view_angles);
  glUniform1f(glGetUniformLocation(p, "extinction"), float(slice_.spec.extinction));
  glUniform4fv(glGetUniformLocation(p, "colour"), 1, glm::value_ptr(colour));
  glUniform1i(glGetUniformLocation(p, "lumislice"), 6);
  glUniform1i(glGetUniformLocation(p, "seen_whole"), 7);
  glBindTextureUnit(6, texture_);
  glBindTextureUnit(7, seen_texture_);
  bind(tubes);
  glUniform1i(glGetUniformLocation(p, "coloured"), tubes.colour_buffer() ? 1 : 0);
  glBindBuffer(GL_DRAW_INDIRECT_BUFFER, draw_);
  glBindVertexArray(vao_);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LESS);
  glDepthMask(GL_FALSE);
  glEnable(GL_BLEND);
  glBlendFunc(GL_ONE, GL_ONE_MINUS_SRC_ALPHA);
  clip_to(p, clip);
  glDrawArraysIndirect(GL_TRIANGLES, nullptr);
  clip_to(p, nullptr);
  glBindBuffer(GL_DRAW_INDIRECT_BUFFER, 0);
  glDisable(GL_BLEND);
  glDepthMask(GL_TRUE);
  check_gl("drawing the slices of " + std::to_string(tubes.segments()) + " yarn segments");
}

std::size_t VolumeYarns::drawn_quads() const {
  GLuint vertices = 0;
  glGetNamedBufferSubData(draw_, 0, sizeof vertices, &vertices);
  return vertices / 6;
}

std::vector<float> VolumeYarns::drawn_distances() const {
  const std::size_t quads = drawn_quads();
  std::vector<std::uint32_t> keys(quads);
  if (quads > 0)
    glGetNamedBufferSubData(buffers_[0], 0, GLsizeiptr(quads * sizeof(std::uint32_t)), keys.data());
  std::vector<float> d(quads);
  for (std::size_t q = 0; q < quads; ++q) // drawn from the last key in use to the first
    d[q] = std::bit_cast<float>(keys[quads - 1 - q]);
  return d;
}

} // namespace kf::render
