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

/// Word i of a packed run of several columns (column-major: column c's words from start[c]):
/// the column found by a walk over at most kPackedColumns starts, then as MoveWords.
template <bool Gather>
struct MoveColumnWords {
  std::uint32_t* packed;
  const std::uint32_t* rows;
  std::uint32_t* column[kPackedColumns];
  std::size_t start[kPackedColumns + 1]; // in words; start[count] = the run's length
  std::uint32_t words[kPackedColumns];
  int count;
  KF_HD KF_INLINE void operator()(std::size_t i) const {
    int c = 0;
    while (c + 1 < count && i >= start[c + 1])
      ++c;
    const std::size_t j = i - start[c], k = j / words[c], w = j % words[c];
    std::uint32_t* row = column[c] + std::size_t(rows[k]) * words[c] + w;
    if constexpr (Gather)
      packed[i] = *row;
    else
      *row = packed[i];
  }
};

template <bool Gather>
void move_columns(const Exec& ex, void* run, const RowColumn* cols, std::size_t n_cols,
                  const std::uint32_t* rows, std::size_t n, const char* label) {
  if (n == 0 || n_cols == 0)
    return;
  bool words =
      n_cols <= std::size_t(kPackedColumns) && reinterpret_cast<std::uintptr_t>(run) % 4 == 0;
  for (std::size_t c = 0; c < n_cols && words; ++c)
    words = cols[c].elem_bytes % 4 == 0 && reinterpret_cast<std::uintptr_t>(cols[c].data) % 4 == 0;
  if (!words) { // a launch a column (any element size, any alignment)
    std::size_t at = 0;
    for (std::size_t c = 0; c < n_cols; ++c) {
      unsigned char* part = static_cast<unsigned char*>(run) + at;
      if constexpr (Gather)
        move_rows<true>(ex, part, cols[c].data, rows, n, cols[c].elem_bytes, label);
      else
        move_rows<false>(ex, cols[c].data, part, rows, n, cols[c].elem_bytes, label);
      at += n * cols[c].elem_bytes;
    }
    return;
  }
  MoveColumnWords<Gather> m{static_cast<std::uint32_t*>(run), rows, {}, {}, {}, 0};
  std::size_t at = 0;
  for (std::size_t c = 0; c < n_cols; ++c) {
    if (cols[c].elem_bytes == 0)
      continue;
    m.column[m.count] = static_cast<std::uint32_t*>(cols[c].data);
    m.words[m.count] = static_cast<std::uint32_t>(cols[c].elem_bytes / 4);
    m.start[m.count] = at;
    at += n * m.words[m.count];
    ++m.count;
  }
  m.start[m.count] = at;
  if (m.count)
    for_each(ex, at, m, label);
}

struct SetAt {
  std::uint32_t* flags;
  const std::uint32_t* rows;
  std::uint32_t value;
  KF_HD KF_INLINE void operator()(std::size_t k) const { flags[rows[k]] = value; }
};

} // namespace

void flag_all_but(const Exec& ex, std::uint32_t* flags, std::size_t n, const std::uint32_t* gone,
                  std::size_t n_gone, const char* label) {
  for_each(ex, n, FillWith<std::uint32_t>{flags, 1u}, label);
  set_listed(ex, flags, gone, n_gone, 0u, label);
}

void flag_only(const Exec& ex, std::uint32_t* flags, std::size_t n, const std::uint32_t* rows,
               std::size_t count, const char* label) {
  for_each(ex, n, FillWith<std::uint32_t>{flags, 0u}, label);
  set_listed(ex, flags, rows, count, 1u, label);
}

void set_listed(const Exec& ex, std::uint32_t* flags, const std::uint32_t* rows, std::size_t count,
                std::uint32_t value, const char* label) {
  for_each(ex, count, SetAt{flags, rows, value}, label);
}

void gather_rows(const Exec& ex, void* dst, const void* src, const std::uint32_t* rows,
                 std::size_t n, std::size_t elem_bytes, const char* label) {
  move_rows<true>(ex, dst, src, rows, n, elem_bytes, label);
}

void scatter_rows(const Exec& ex, void* dst, const std::uint32_t* rows, const void* src,
                  std::size_t n, std::size_t elem_bytes, const char* label) {
  move_rows<false>(ex, dst, src, rows, n, elem_bytes, label);
}

void gather_columns(const Exec& ex, void* dst, const RowColumn* cols, std::size_t n_cols,
                    const std::uint32_t* rows, std::size_t n, const char* label) {
  move_columns<true>(ex, dst, cols, n_cols, rows, n, label);
}

void scatter_columns(const Exec& ex, const RowColumn* cols, std::size_t n_cols,
                     const std::uint32_t* rows, const void* src, std::size_t n, const char* label) {
  move_columns<false>(ex, const_cast<void*>(src), cols, n_cols, rows, n, label);
}

} // namespace kf::exec
