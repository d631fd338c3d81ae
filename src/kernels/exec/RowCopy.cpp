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

/// Word i of a batch of packed messages: the message found by a walk over at most
/// kBatchedMessages starts, then its column by a walk over at most kPackedColumns (column-major
/// within a message: column c's words from n times the row words before it), then as MoveWords.
template <bool Gather>
struct MoveMessageWords {
  struct Part {
    std::uint32_t* packed;
    const std::uint32_t* rows; // null: first + k
    std::size_t first, n;
    std::size_t start; // the message's first word in the batch
  };
  std::uint32_t* column[kPackedColumns];
  std::uint32_t words[kPackedColumns];
  std::uint32_t row_start[kPackedColumns + 1]; // a row's words before column c
  int count;
  Part part[kBatchedMessages];
  int parts;
  KF_HD KF_INLINE void operator()(std::size_t i) const {
    int m = 0;
    while (m + 1 < parts && i >= part[m + 1].start)
      ++m;
    const Part& p = part[m];
    const std::size_t j = i - p.start;
    int c = 0;
    while (c + 1 < count && j >= p.n * row_start[c + 1])
      ++c;
    const std::size_t r = j - p.n * row_start[c], k = r / words[c], w = r % words[c];
    const std::size_t at = p.rows ? std::size_t(p.rows[k]) : p.first + k;
    std::uint32_t* row = column[c] + at * words[c] + w;
    if constexpr (Gather)
      p.packed[j] = *row;
    else
      *row = p.packed[j];
  }
};

/// One message, one column, any element size: a launch.
template <bool Gather>
void move_column(const Exec& ex, unsigned char* packed, const RowColumn& col, const RowMessage& msg,
                 const char* label) {
  auto* data = static_cast<unsigned char*>(col.data);
  const std::size_t bytes = msg.n * col.elem_bytes;
  if (msg.rows == nullptr) { // consecutive rows: a plain copy
    unsigned char* rows = data + msg.first * col.elem_bytes;
    if constexpr (Gather)
      copy_bytes(packed, ex.backend, rows, ex.backend, bytes);
    else
      copy_bytes(rows, ex.backend, packed, ex.backend, bytes);
  } else if constexpr (Gather) {
    move_rows<true>(ex, packed, data, msg.rows, msg.n, col.elem_bytes, label);
  } else {
    move_rows<false>(ex, data, packed, msg.rows, msg.n, col.elem_bytes, label);
  }
}

template <bool Gather>
void move_messages(const Exec& ex, const RowColumn* cols, std::size_t n_cols,
                   const RowMessage* msgs, std::size_t n_msgs, const char* label) {
  bool words = n_cols <= std::size_t(kPackedColumns);
  for (std::size_t c = 0; c < n_cols && words; ++c)
    words = cols[c].elem_bytes % 4 == 0 && reinterpret_cast<std::uintptr_t>(cols[c].data) % 4 == 0;
  for (std::size_t m = 0; m < n_msgs && words; ++m)
    words = reinterpret_cast<std::uintptr_t>(msgs[m].packed) % 4 == 0;
  if (!words) { // a launch a message and a column (any element size, any alignment)
    for (std::size_t m = 0; m < n_msgs; ++m) {
      std::size_t at = 0;
      for (std::size_t c = 0; c < n_cols; ++c) {
        if (msgs[m].n && cols[c].elem_bytes)
          move_column<Gather>(ex, static_cast<unsigned char*>(msgs[m].packed) + at, cols[c],
                              msgs[m], label);
        at += msgs[m].n * cols[c].elem_bytes;
      }
    }
    return;
  }
  MoveMessageWords<Gather> f{};
  std::uint32_t row = 0;
  for (std::size_t c = 0; c < n_cols; ++c) {
    if (cols[c].elem_bytes == 0)
      continue;
    f.column[f.count] = static_cast<std::uint32_t*>(cols[c].data);
    f.words[f.count] = static_cast<std::uint32_t>(cols[c].elem_bytes / 4);
    f.row_start[f.count] = row;
    row += f.words[f.count];
    ++f.count;
  }
  f.row_start[f.count] = row;
  if (f.count == 0)
    return;
  // Batches of kBatchedMessages non-empty messages: a launch each.
  std::size_t m = 0;
  while (m < n_msgs) {
    f.parts = 0;
    std::size_t total = 0;
    for (; m < n_msgs && f.parts < kBatchedMessages; ++m) {
      if (msgs[m].n == 0)
        continue;
      f.part[f.parts++] = {static_cast<std::uint32_t*>(msgs[m].packed), msgs[m].rows, msgs[m].first,
                           msgs[m].n, total};
      total += msgs[m].n * row;
    }
    if (total)
      for_each(ex, total, f, label);
  }
}

struct SetAt {
  std::uint32_t* flags;
  const std::uint32_t* rows;
  std::uint32_t value;
  KF_HD KF_INLINE void operator()(std::size_t k) const { flags[rows[k]] = value; }
};

} // namespace

void fill_flags(const Exec& ex, std::uint32_t* flags, std::size_t n, std::uint32_t value,
                const char* label) {
  for_each(ex, n, FillWith<std::uint32_t>{flags, value}, label);
}

void flag_all_but(const Exec& ex, std::uint32_t* flags, std::size_t n, const std::uint32_t* gone,
                  std::size_t n_gone, const char* label) {
  fill_flags(ex, flags, n, 1u, label);
  set_listed(ex, flags, gone, n_gone, 0u, label);
}

void flag_only(const Exec& ex, std::uint32_t* flags, std::size_t n, const std::uint32_t* rows,
               std::size_t count, const char* label) {
  fill_flags(ex, flags, n, 0u, label);
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
  const RowMessage one{dst, rows, 0, n};
  move_messages<true>(ex, cols, n_cols, &one, 1, label);
}

void scatter_columns(const Exec& ex, const RowColumn* cols, std::size_t n_cols,
                     const std::uint32_t* rows, const void* src, std::size_t n, const char* label) {
  const RowMessage one{const_cast<void*>(src), rows, 0, n};
  move_messages<false>(ex, cols, n_cols, &one, 1, label);
}

void gather_messages(const Exec& ex, const RowColumn* cols, std::size_t n_cols,
                     const RowMessage* messages, std::size_t n_messages, const char* label) {
  move_messages<true>(ex, cols, n_cols, messages, n_messages, label);
}

void scatter_messages(const Exec& ex, const RowColumn* cols, std::size_t n_cols,
                      const RowMessage* messages, std::size_t n_messages, const char* label) {
  move_messages<false>(ex, cols, n_cols, messages, n_messages, label);
}

} // namespace kf::exec
