#include "comm/RowCopier.hpp"

#include <cstring>

namespace kf::comm {

void RowCopier::gather(std::span<const Column> cols, std::span<const std::uint32_t> rows,
                       unsigned char* out) {
  for (const Column& c : cols) {
    const auto* src = static_cast<const unsigned char*>(c.data);
    for (std::uint32_t i : rows) {
      std::memcpy(out, src + std::size_t(i) * c.elem_bytes, c.elem_bytes);
      out += c.elem_bytes;
    }
  }
}

void RowCopier::scatter(std::span<const Column> cols, std::span<const std::uint32_t> rows,
                        const unsigned char* in) {
  for (const Column& c : cols) {
    auto* dst = static_cast<unsigned char*>(c.data);
    for (std::uint32_t i : rows) {
      std::memcpy(dst + std::size_t(i) * c.elem_bytes, in, c.elem_bytes);
      in += c.elem_bytes;
    }
  }
}

void RowCopier::put(std::span<const Column> cols, std::size_t first, std::size_t n,
                    const unsigned char* in) {
  if (n == 0)
    return;
  for (const Column& c : cols) {
    std::memcpy(static_cast<unsigned char*>(c.data) + first * c.elem_bytes, in, n * c.elem_bytes);
    in += n * c.elem_bytes;
  }
}

void RowCopier::compact(std::span<const Column> cols, std::span<const std::uint32_t> keep) {
  for (const Column& c : cols) {
    auto* d = static_cast<unsigned char*>(c.data);
    const std::size_t e = c.elem_bytes;
    for (std::size_t k = 0; k < keep.size(); ++k) // keep[k] >= k: forward moves only
      if (keep[k] != k)
        std::memcpy(d + k * e, d + std::size_t(keep[k]) * e, e);
  }
}

RowCopier& host_rows() {
  static RowCopier host;
  return host;
}

} // namespace kf::comm
