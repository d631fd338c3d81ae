#pragma once
// Reads a snapshot written by SnapshotWriter (restart, rendering, tests).
#include "io/Frame.hpp"
#include "io/SnapshotInfo.hpp"

#include <mpi.h>

#include <string>
#include <vector>

namespace kf::io {

/// Collective over comm: every rank gets the whole frame (all rows of every phase and field, with
/// element type and components as stored, plus time/step/frame/precision/scene and the double
/// scalars). A missing or unreadable file throws kf::Error naming the path.
Frame read_snapshot(MPI_Comm comm, const std::string& path);

/// Collective over comm: like read_snapshot, but rank r of P gets only rows
/// [r*N/P, (r+1)*N/P) of each phase (N its global count), so the shares concatenate in rank order.
Frame read_snapshot_share(MPI_Comm comm, const std::string& path);

/// Collective over comm: the phases named in `shared` as read_snapshot_share reads them (rank r
/// of P gets rows [r*N/P, (r+1)*N/P)), the others whole (Frame::shared_phases names the former):
/// a restart of a job too large for one host reads its fluid and boundary in shares.
Frame read_snapshot_shares(MPI_Comm comm, const std::string& path,
                           const std::vector<std::string>& shared);

/// One process, no MPI: the file's index, time and phase/field layout, without particle data.
SnapshotInfo read_snapshot_info(const std::string& path);

} // namespace kf::io
