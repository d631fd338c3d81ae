#include "render/VolumeYarns.hpp"

#include "core/Error.hpp"
#include "render/GlBuffers.hpp"
#include "render/Shaders.hpp"
#include "render/TubeRenderer.hpp"

#include <epoxy/gl.h>
#include <glm/gtc/type_ptr.hpp>

#include <algorithm>
#include <bit>
#include <cmath>
#include <string>

namespace kf::render {

VolumeYarns::VolumeYarns(const LumisliceSpec& spec, bool sort_on_cuda, int slices,
                         double detail_pixels)
    : slice_(make_lumislice(spec)), slices_(slices), detail_pixels_(detail_pixels),
      program_("yarn_slice.vert + yarn_slice.frag", shaders::kYarnSliceVert,
               shaders::kYarnSliceFrag),
      order_program_(
          ShaderProgram::compute("yarn_slices.comp", with_light_lookups(shaders::kYarnSlicesComp))),
      sort_(sort_on_cuda) {
  if (slices < 1 || slices > 4)
    throw Error("render: a volumetric yarn takes 1 to 4 slices a segment, not " +
                std::to_string(slices));
  // The lumislice as a texture array of 8-bit layers: the density, the light a direction, the
  // ambient light's share.
  const int n = spec.texels, layers = 2 + spec.light_directions;
  std::vector<std::uint8_t> texels(std::size_t(layers) * n * n);
  auto to_byte = [](float v) { return std::uint8_t(std::lround(255 * std::clamp(v, 0.0f, 1.0f))); };
  std::transform(slice_.density.begin(), slice_.density.end(), texels.begin(), to_byte);
  std::transform(slice_.light.begin(), slice_.light.end(), texels.begin() + std::size_t(n) * n,
                 to_byte);
  std::transform(slice_.ambient.begin(), slice_.ambient.end(),
                 texels.begin() + std::size_t(layers - 1) * n * n, to_byte);
  glCreateTextures(GL_TEXTURE_2D_ARRAY, 1, &texture_);
  // Mipmapped: a yarn is often a few pixels wide, its fibres far under a pixel; the levels
  // average them (their coverage, the light through them) instead of aliasing into noise.
  const int levels = 1 + int(std::floor(std::log2(double(n))));
  glTextureStorage3D(texture_, levels, GL_R8, n, n, layers);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  glTextureSubImage3D(texture_, 0, 0, 0, 0, n, n, layers, GL_RED, GL_UNSIGNED_BYTE, texels.data());
  glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  glGenerateTextureMipmap(texture_);
  glTextureParameteri(texture_, GL_TEXTURE_MIN_FILTER, GL_LINEAR_MIPMAP_LINEAR);
  glTextureParameteri(texture_, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glTextureParameteri(texture_, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glTextureParameteri(texture_, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  // The section seen whole: offset along s, view angle along t (periodic); layers its opacity,
  // the ambient light's and each direction's light.
  const int angles = spec.view_angles;
  std::vector<std::uint8_t> seen(std::size_t(layers) * n * angles);
  const std::size_t plane = std::size_t(n) * angles;
  std::transform(slice_.seen_alpha.begin(), slice_.seen_alpha.end(), seen.begin(), to_byte);
  std::transform(slice_.seen_ambient.begin(), slice_.seen_ambient.end(), seen.begin() + plane,
                 to_byte);
  std::transform(slice_.seen_light.begin(), slice_.seen_light.end(), seen.begin() + 2 * plane,
                 to_byte);
  glCreateTextures(GL_TEXTURE_2D_ARRAY, 1, &seen_texture_);
  const int seen_levels = 1 + int(std::floor(std::log2(double(std::max(n, angles)))));
  glTextureStorage3D(seen_texture_, seen_levels, GL_R8, n, angles, layers);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  glTextureSubImage3D(seen_texture_, 0, 0, 0, 0, n, angles, layers, GL_RED, GL_UNSIGNED_BYTE,
                      seen.data());
  glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  glGenerateTextureMipmap(seen_texture_);
  glTextureParameteri(seen_texture_, GL_TEXTURE_MIN_FILTER, GL_LINEAR_MIPMAP_LINEAR);
  glTextureParameteri(seen_texture_, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glTextureParameteri(seen_texture_, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glTextureParameteri(seen_texture_, GL_TEXTURE_WRAP_T, GL_REPEAT);
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
  for (GLuint i = 0; i < 4; ++i)
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, i, tubes.frame_buffer(int(i)));
  for (GLuint i = 0; i < 4; ++i)
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 8 + i, buffers_[i]);
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 12, draw_);
  const unsigned p = order_program_.id();
  use_lit_program(p, view, light); // the shadow maps' uniforms and sampler
  const glm::vec3 toward = glm::normalize(light.toward_light);
  glProgramUniform3fv(p, glGetUniformLocation(p, "toward_light"), 1, glm::value_ptr(toward));
  const glm::vec3 eye(glm::inverse(view.view)[3]);
  // Pixels a metre at a metre from the eye: the projection's vertical scale over half a picture.
  const bool detail = detail_pixels_ > 0 && height > 0;
  const float pixel_scale = detail ? 0.5f * float(height) * view.projection[1][1] : 0.0f;
  const GLuint group = detail ? 8 : 1;
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
                       const Lighting& light) {
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
  for (GLuint i = 0; i < 4; ++i)
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, i, tubes.frame_buffer(int(i)));
  for (GLuint i = 1; i < 4; ++i)
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 8 + i, buffers_[i]);
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 12, draw_);
  glBindBuffer(GL_DRAW_INDIRECT_BUFFER, draw_);
  glBindVertexArray(vao_);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LESS);
  glDepthMask(GL_FALSE);
  glEnable(GL_BLEND);
  glBlendFunc(GL_ONE, GL_ONE_MINUS_SRC_ALPHA);
  glDrawArraysIndirect(GL_TRIANGLES, nullptr);
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
