#pragma once
// GL buffer storage reused from frame to frame.
#include <cstddef>

namespace kf::render {

/// `buffer` when it holds `bytes` (its `capacity`), else a new immutable buffer of that size
/// (GL_DYNAMIC_STORAGE_BIT: filled by glNamedBufferSubData) replacing it: storage grows, never
/// shrinks, so a film allocates once. 0 is no buffer yet. A new buffer holds `headroom` times
/// the bytes asked for (a film's growing splash: fewer reallocations, each a stall).
unsigned grown_buffer(unsigned buffer, std::size_t& capacity, std::size_t bytes,
                      double headroom = 1.0);

} // namespace kf::render
