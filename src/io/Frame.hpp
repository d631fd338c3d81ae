#pragma once
// What a snapshot holds, independent of physics: per phase ("fluid", "boundary", ...) a set of
// named per-particle arrays, plus run attributes. The simulation fills a Frame from its particle
// sets; restart reads one back.
#include <cstddef>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace kf::io {

enum class DType { F32, F64, U32, U64, I32 };

std::size_t dtype_size(DType t);

/// One per-particle array on this rank: count rows of `components` values of `type`.
struct Field {
  std::string name; // "position", "velocity", "id", "density", ...
  DType type = DType::F64;
  int components = 1;
  std::size_t count = 0;            // rows on this rank
  std::vector<unsigned char> bytes; // count * components * dtype_size(type)

  template <typename T>
  static Field from(std::string name, const std::vector<T>& v, int components);
  template <typename T>
  std::vector<T> as() const; // throws kf::Error when T does not match type
};

struct Phase {
  std::string name;
  std::vector<Field> fields;
  const Field* find(const std::string& field) const;
};

struct Frame {
  double time = 0;
  std::uint64_t step = 0;
  std::uint64_t index = 0; // frame number (file frame_%06d.h5)
  std::string scene_text;  // the scene the run used
  // The folder its files (OBJ meshes) are named relative to: the scene file's, absolute; empty
  // in snapshots written before it was recorded.
  std::string scene_dir;
  std::string precision;                               // "float" | "double"
  std::vector<std::pair<std::string, double>> scalars; // extra attributes (dt, energy, ...)
  std::vector<Phase> phases;
  // Phases whose rows here are this rank's contiguous share of the file's, the shares in rank
  // order (read_snapshot_shares); the others hold every row.
  std::vector<std::string> shared_phases;
  int share_ranks = 1; // the ranks the shares were read over
  const Phase* find(const std::string& phase) const;
  bool shared(const std::string& phase) const;
};

} // namespace kf::io
