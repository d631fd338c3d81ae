#include "render/GlBuffers.hpp"

#include <epoxy/gl.h>

#include <algorithm>

namespace kf::render {

unsigned grown_buffer(unsigned buffer, std::size_t& capacity, std::size_t bytes, double headroom) {
  if (bytes <= capacity && buffer != 0)
    return buffer;
  bytes = std::size_t(double(bytes) * std::max(1.0, headroom));
  glDeleteBuffers(1, &buffer);
  glCreateBuffers(1, &buffer);
  bytes = std::max<std::size_t>(bytes, 16); // a buffer of no bytes is an error
  glNamedBufferStorage(buffer, GLsizeiptr(bytes), nullptr, GL_DYNAMIC_STORAGE_BIT);
  capacity = bytes;
  return buffer;
}

} // namespace kf::render
