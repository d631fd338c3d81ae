#pragma once
// Writes one HDF5 file per output frame, collectively over the ranks of a communicator, and keeps
// the directory's XDMF index (snapshots.xmf) for ParaView up to date.
#include "io/Frame.hpp"
#include "io/SnapshotInfo.hpp"

#include <mpi.h>

#include <cstdint>
#include <map>
#include <string>

namespace kf::io {

/// "frame_000012.h5" for index 12.
std::string snapshot_file_name(std::uint64_t index);

/// Collective: writes f to path through path + ".tmp" and a rename once every rank has closed
/// it, so `path` is complete or absent whenever the job dies. Returns path.
std::string publish_snapshot(MPI_Comm comm, const std::string& path, const Frame& f);

/// File layout: root attributes time, step, frame, precision, scene, units, knitflow_version and
/// one double per Frame::scalars entry; a group per phase with attribute `count` (global rows) and
/// one dataset per field, [count] or [count, components], in the field's own element type.
class SnapshotWriter {
public:
  /// Collective. Rank 0 creates dir if missing and indexes the frame_*.h5 files already there, so
  /// a restarted run keeps the earlier frames in snapshots.xmf.
  SnapshotWriter(MPI_Comm comm, std::string dir);

  /// Collective: every rank passes its own rows of the same phases and fields. Writes
  /// dir/frame_%06d.h5 for f.index (through a .tmp name and a rename, so a crash never leaves a
  /// broken newest snapshot), then rewrites snapshots.xmf, dropping frames after f.index (they
  /// belong to an abandoned run). Returns the file's path.
  std::string write(const Frame& f);

  const std::string& dir() const { return dir_; }

private:
  MPI_Comm comm_;
  std::string dir_;
  std::map<std::uint64_t, SnapshotInfo> index_; // rank 0: the frames snapshots.xmf lists
};

} // namespace kf::io
