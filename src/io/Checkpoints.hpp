#pragma once
// Full-state checkpoints (P8): snapshot files in their own directory, written on a cadence of
// steps or wall time, the newest K kept. Each is published whole (publish_snapshot: a temporary
// name, then a rename), so a job killed at any moment -- in the middle of a write too -- leaves
// only complete checkpoints, and `knitflow run --restart latest` picks the newest complete state
// among them and the output frames.
#include "io/Frame.hpp"

#include <mpi.h>

#include <cstdint>
#include <string>

namespace kf::io {

/// "checkpoint_000000012345.h5" after step 12345.
std::string checkpoint_file_name(std::uint64_t step);

class CheckpointWriter {
public:
  /// Collective. Rank 0 creates dir and removes the .tmp files a killed write left there.
  CheckpointWriter(MPI_Comm comm, std::string dir, int keep);
  /// Collective: dir/checkpoint_<step>.h5, then the oldest beyond `keep` removed. Returns the
  /// path.
  std::string write(const Frame& f, std::uint64_t step);
  const std::string& dir() const { return dir_; }

private:
  MPI_Comm comm_;
  std::string dir_;
  int keep_;
};

/// The newest complete state under a run's output directory: its checkpoints
/// (output_dir/checkpoints/checkpoint_*.h5) and its frames (output_dir/frame_*.h5), the one with
/// the latest simulated time (a checkpoint before a frame of the same time). Unreadable files are
/// passed over; none at all is an InputError naming the directory.
std::string latest_state(const std::string& output_dir);

} // namespace kf::io
