#pragma once
// Rows of byte columns gathered into and scattered from packed runs, on either backend: the
// packing of the ranks' halo and migration messages (domain/DeviceRows). One source for both
// backends (RowCopy.cpp is compiled by nvcc in the CUDA build).
#include "kernels/exec/Algorithms.hpp"

#include <cstddef>
#include <cstdint>

namespace kf::exec {

/// dst[k] = src[rows[k]] for k < n, elements of elem_bytes bytes; all on ex.backend, dst not
/// overlapping src.
void gather_rows(const Exec& ex, void* dst, const void* src, const std::uint32_t* rows,
                 std::size_t n, std::size_t elem_bytes, const char* label);
/// dst[rows[k]] = src[k] for k < n (rows distinct).
void scatter_rows(const Exec& ex, void* dst, const std::uint32_t* rows, const void* src,
                  std::size_t n, std::size_t elem_bytes, const char* label);

/// A column of rows: `elem_bytes` bytes a row from `data`.
struct RowColumn {
  void* data = nullptr;
  std::size_t elem_bytes = 0;
};
/// Every column's rows[k] packed into one run, column after column (column c's n rows start at
/// n times the row bytes of the columns before it): one launch for up to kPackedColumns
/// columns of 4-byte words, else one a column.
inline constexpr int kPackedColumns = 16;
void gather_columns(const Exec& ex, void* dst, const RowColumn* cols, std::size_t n_cols,
                    const std::uint32_t* rows, std::size_t n, const char* label);
/// The inverse: column c's rows[k] from the packed run (rows distinct).
void scatter_columns(const Exec& ex, const RowColumn* cols, std::size_t n_cols,
                     const std::uint32_t* rows, const void* src, std::size_t n, const char* label);

/// One message of a batch: n rows packed at `packed` as gather_columns packs them; the rows are
/// rows[k], or first + k where rows is null (ghosts received into consecutive slots).
struct RowMessage {
  void* packed = nullptr;
  const std::uint32_t* rows = nullptr;
  std::size_t first = 0;
  std::size_t n = 0;
};
/// The messages of a halo refresh (one a peer) in one launch: a refresh's latency was its
/// launches, a pack and a copy a column for every peer (P9). Up to kBatchedMessages messages of
/// word columns in one launch; more, or other columns, a launch a message (and a column).
inline constexpr int kBatchedMessages = 32;
void gather_messages(const Exec& ex, const RowColumn* cols, std::size_t n_cols,
                     const RowMessage* messages, std::size_t n_messages, const char* label);
/// The inverse: each message's values written to its rows (distinct over all messages).
void scatter_messages(const Exec& ex, const RowColumn* cols, std::size_t n_cols,
                      const RowMessage* messages, std::size_t n_messages, const char* label);

/// flags[i] = value for i < n.
void fill_flags(const Exec& ex, std::uint32_t* flags, std::size_t n, std::uint32_t value,
                const char* label);
/// flags[rows[k]] = value for k < count (rows may repeat).
void set_listed(const Exec& ex, std::uint32_t* flags, const std::uint32_t* rows, std::size_t count,
                std::uint32_t value, const char* label);
/// flags[i] = 0 for i < n, then flags[rows[k]] = 1 for k < count: the listed rows.
void flag_only(const Exec& ex, std::uint32_t* flags, std::size_t n, const std::uint32_t* rows,
               std::size_t count, const char* label);
/// flags[i] = 1 for i < n, then flags[gone[k]] = 0 for k < n_gone: the rows that stay.
void flag_all_but(const Exec& ex, std::uint32_t* flags, std::size_t n, const std::uint32_t* gone,
                  std::size_t n_gone, const char* label);

} // namespace kf::exec
