#pragma once
// The shape of one snapshot file without its particle data: what the XDMF index needs and what a
// reader learns before it reads rows.
#include "io/Frame.hpp"

#include <cstdint>
#include <string>
#include <vector>

namespace kf::io {

struct FieldLayout {
  std::string name;
  DType type = DType::F64;
  int components = 1;
};

struct PhaseLayout {
  std::string name;
  std::uint64_t count = 0; // rows over all ranks
  std::vector<FieldLayout> fields;
};

struct SnapshotInfo {
  std::string file; // file name within the snapshot directory, e.g. "frame_000012.h5"
  std::uint64_t index = 0;
  double time = 0;
  std::vector<PhaseLayout> phases;
};

} // namespace kf::io
