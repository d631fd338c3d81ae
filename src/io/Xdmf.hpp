#pragma once
// The XDMF 3 index that lets ParaView open a directory of snapshots as one time series.
#include "io/SnapshotInfo.hpp"

#include <string>
#include <vector>

namespace kf::io {

/// A temporal collection over `frames` (in the order given); per frame a spatial collection with
/// one Polyvertex grid per non-empty phase that has a 3-component float `position`, and an
/// attribute per 1-component (Scalar) or 3-component (Vector) field. Data items reference
/// "<file>:/<phase>/<field>" relative to the index file.
std::string xdmf_document(const std::vector<SnapshotInfo>& frames);

/// Writes xdmf_document(frames) to path atomically (a .tmp file renamed over path).
void write_xdmf(const std::string& path, const std::vector<SnapshotInfo>& frames);

} // namespace kf::io
