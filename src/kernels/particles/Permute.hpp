#pragma once
#include "kernels/exec/Algorithms.hpp"

namespace kf {

/// Reorders one field by a sort permutation, through a scratch buffer that is then swapped in.
/// A permutation shorter than the field keeps only the elements it names (compaction).
template <typename U>
void permute(const exec::Exec& ex, const exec::DeviceBuffer<std::uint32_t>& perm,
             exec::DeviceBuffer<U>& field, exec::DeviceBuffer<U>& scratch, const char* label) {
  scratch.resize_snug(perm.size());
  exec::gather(ex, perm, field, scratch, label);
  field.swap(scratch);
}

} // namespace kf
