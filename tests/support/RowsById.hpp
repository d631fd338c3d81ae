#pragma once
// One phase of a snapshot frame in id order: what the MPI tests compare between a one-rank and
// a split run (every rank's owned rows gathered when the frame was written split).
#include "io/SnapshotReader.hpp"
#include "support/MpiGather.hpp"

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <initializer_list>
#include <map>
#include <numeric>
#include <set>
#include <string>
#include <vector>

namespace kf::test {

struct RowsById {
  std::vector<std::uint64_t> id;
  std::map<std::string, std::vector<unsigned char>> bytes; // per field, rows in id order
  std::set<std::uint32_t> ranks; // the ranks holding rows (the frame's rank field; none without)
};

/// `phase`'s rows of the fields named (those the frame has) in id order; gather: each rank read
/// its own rows, all of them wanted on every rank (collective).
inline RowsById rows_by_id(const io::Frame& fr, const char* phase, bool gather,
                           std::initializer_list<const char*> fields) {
  const io::Phase& f = *fr.find(phase);
  auto bytes_of = [&](const std::string& name) {
    const auto& b = f.find(name)->bytes;
    return gather ? allgather(b) : b;
  };
  const auto idb = bytes_of("id");
  std::vector<std::uint64_t> id(idb.size() / 8);
  std::memcpy(id.data(), idb.data(), idb.size());
  std::vector<std::size_t> order(id.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](auto a, auto b) { return id[a] < id[b]; });
  RowsById r;
  for (std::size_t k : order)
    r.id.push_back(id[k]);
  for (const char* name : fields) {
    if (!f.find(name))
      continue;
    const auto b = bytes_of(name);
    const std::size_t row = id.empty() ? 0 : b.size() / id.size();
    auto& out = r.bytes[name];
    out.resize(b.size());
    for (std::size_t k = 0; k < order.size(); ++k)
      std::memcpy(out.data() + k * row, b.data() + order[k] * row, row);
  }
  if (f.find("rank")) {
    const auto q = f.find("rank")->as<std::uint32_t>();
    for (std::uint32_t rank : gather ? allgather(q) : q)
      r.ranks.insert(rank);
  }
  return r;
}

} // namespace kf::test
