#include "kernels/exec/RowCopy.hpp"

namespace kf::exec {

namespace {

/// One word (W: 4 bytes where the element size allows, else 1) of the n rows: word i of the
/// packed run is word i % words of row i / words. Packed k <-> column rows[k].
template <typename W, bool Gather>
struct MoveWords {
  W* dst;
  const W* src;
  const std::uint32_t* rows;
  std::size_t words; // a row's
  KF_HD KF_INLINE void operator()(std::size_t i) const {
    const std::size_t k = i / words, w = i % words;
    if constexpr (Gather)
      dst[i] = src[std::size_t(rows[k]) * words + w];
    else
      dst[std::size_t(rows[k]) * words + w] = src[i];
  }
};

template <bool Gather>
void move_rows(const Exec& ex, void* dst, const void* src, const std::uint32_t* rows, std::size_t n,
               std::size_t elem_bytes, const char* label) {
  if (n == 0 || elem_bytes == 0)
    return;
  // Every column here is 4-byte aligned and sized (floats, doubles, ids, vectors of them); the
  // byte path keeps any other correct.
  const bool aligned = elem_bytes % 4 == 0 && reinterpret_cast<std::uintptr_t>(dst) % 4 == 0 &&
                       reinterpret_cast<std::uintptr_t>(src) % 4 == 0;
  if (aligned) {
    const std::size_t words = elem_bytes / 4;
    for_each(ex, n * words,
             MoveWords<std::uint32_t, Gather>{static_cast<std::uint32_t*>(dst),
                                              static_cast<const std::uint32_t*>(src), rows, words},
             label);
  } else {
    for_each(ex, n * elem_bytes,
             MoveWords<unsigned char, Gather>{static_cast<unsigned char*>(dst),
                                              static_cast<const unsigned char*>(src), rows,
                                              elem_bytes},
             label);
  }
}

struct ClearAt {
  std::uint32_t* flags;
  const std::uint32_t* rows;
  KF_HD KF_INLINE void operator()(std::size_t k) const { flags[rows[k]] = 0; }
};

} // namespace

void flag_all_but(const Exec& ex, std::uint32_t* flags, std::size_t n, const std::uint32_t* gone,
                  std::size_t n_gone, const char* label) {
  for_each(ex, n, FillWith<std::uint32_t>{flags, 1u}, label);
  for_each(ex, n_gone, ClearAt{flags, gone}, label);
}

void gather_rows(const Exec& ex, void* dst, const void* src, const std::uint32_t* rows,
                 std::size_t n, std::size_t elem_bytes, const char* label) {
  move_rows<true>(ex, dst, src, rows, n, elem_bytes, label);
}

void scatter_rows(const Exec& ex, void* dst, const std::uint32_t* rows, const void* src,
                  std::size_t n, std::size_t elem_bytes, const char* label) {
  move_rows<false>(ex, dst, src, rows, n, elem_bytes, label);
}

} // namespace kf::exec
