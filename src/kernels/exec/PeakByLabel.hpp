#pragma once
// Where a run's memory went: what a backend held at its peak (held_bytes().peak), summed by the
// label each allocation was made with (a buffer's name). Kept by the ledger behind alloc_bytes.
#include "kernels/exec/Backend.hpp"

#include <cstddef>
#include <string>
#include <vector>

namespace kf::exec {

struct LabelledBytes {
  std::string label;
  std::size_t bytes = 0;
};

/// The peak's bytes by label, largest first (ties by label); reset_peak_bytes starts it again
/// from what is held then.
std::vector<LabelledBytes> peak_by_label(Backend b);

/// "prefix.suffix", kept for the process's life: a label for the buffers of one instance of a
/// class that holds several (a grid's "coupling.grid" + "start"), which DeviceBuffer keeps as a
/// pointer.
const char* joined_label(const char* prefix, const char* suffix);

} // namespace kf::exec
