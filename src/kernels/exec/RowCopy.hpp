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

/// flags[i] = 1 for i < n, then flags[gone[k]] = 0 for k < n_gone: the rows that stay.
void flag_all_but(const Exec& ex, std::uint32_t* flags, std::size_t n, const std::uint32_t* gone,
                  std::size_t n_gone, const char* label);

} // namespace kf::exec
