// The halo's packing (kernels/exec/RowCopy): several columns' rows gathered into one packed run,
// column after column, and scattered back, in one launch where every column is of 4-byte words
// (up to kPackedColumns) and a launch a column otherwise; a refresh's messages (one a peer, listed
// rows or consecutive slots) in one launch. Checked against a host loop over the
// same layout, byte for byte, on the CPU backend and on CUDA where a GPU is visible; outputs are
// poisoned first so that an unwritten byte shows.
#include "kernels/exec/DeviceBuffer.hpp"
#include "kernels/exec/RowCopy.hpp"

#include "support/Backends.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <numeric>
#include <random>
#include <vector>

using namespace kf;

namespace {

using test::backends;

/// Columns of the given element sizes over `rows` rows, filled with distinct bytes.
struct Columns {
  std::vector<std::vector<unsigned char>> host;
  std::vector<exec::DeviceBuffer<unsigned char>> dev;
  Columns(exec::Backend b, const std::vector<std::size_t>& sizes, std::size_t rows) {
    std::mt19937 rng(11);
    for (std::size_t s : sizes) {
      std::vector<unsigned char> h(s * rows);
      for (auto& c : h)
        c = static_cast<unsigned char>(rng());
      host.push_back(h);
      dev.emplace_back(b, 0, "test.column");
      dev.back().assign(h);
    }
  }
  std::vector<exec::RowColumn> refs(const std::vector<std::size_t>& sizes) {
    std::vector<exec::RowColumn> r;
    for (std::size_t c = 0; c < sizes.size(); ++c)
      r.push_back({dev[c].data(), sizes[c]});
    return r;
  }
};

/// The packed run a host loop makes: column after column, rows[k] of each.
std::vector<unsigned char> packed_on_host(const Columns& cols,
                                          const std::vector<std::size_t>& sizes,
                                          const std::vector<std::uint32_t>& rows) {
  std::vector<unsigned char> out;
  for (std::size_t c = 0; c < sizes.size(); ++c)
    for (std::uint32_t r : rows)
      out.insert(out.end(), cols.host[c].begin() + std::ptrdiff_t(r * sizes[c]),
                 cols.host[c].begin() + std::ptrdiff_t((r + 1) * sizes[c]));
  return out;
}

void round_trip(exec::Backend b, const std::vector<std::size_t>& sizes, const char* what) {
  SCOPED_TRACE(std::string(what) + (b == exec::Backend::Cpu ? ", CPU" : ", CUDA"));
  const std::size_t n_rows = 3001;
  Columns cols(b, sizes, n_rows);
  // Every third row, shuffled: a send list is any set of distinct rows in any order.
  std::vector<std::uint32_t> rows;
  for (std::uint32_t r = 1; r < n_rows; r += 3)
    rows.push_back(r);
  std::shuffle(rows.begin(), rows.end(), std::mt19937(5));
  exec::DeviceBuffer<std::uint32_t> drows(b, 0, "test.rows");
  drows.assign(rows);
  const auto want = packed_on_host(cols, sizes, rows);

  exec::DeviceBuffer<unsigned char> run(b, want.size(), "test.run");
  run.poison();
  const auto refs = cols.refs(sizes);
  exec::gather_columns({b}, run.data(), refs.data(), refs.size(), drows.data(), rows.size(),
                       "test.pack");
  EXPECT_EQ(run.to_host(), want) << "gathered run";

  // Scattered into poisoned columns: the listed rows are the run's, the others stay poisoned.
  for (auto& d : cols.dev)
    d.poison();
  exec::scatter_columns({b}, refs.data(), refs.size(), drows.data(), run.data(), rows.size(),
                        "test.unpack");
  for (std::size_t c = 0; c < sizes.size(); ++c) {
    std::vector<unsigned char> expect(sizes[c] * n_rows, 0xFF);
    for (std::uint32_t r : rows)
      if (sizes[c] > 0) // an empty column has no storage to copy from (memcpy takes no null)
        std::memcpy(expect.data() + r * sizes[c], cols.host[c].data() + r * sizes[c], sizes[c]);
    EXPECT_EQ(cols.dev[c].to_host(), expect) << "column " << c << " scattered";
  }
}

/// A refresh's messages in one batch: `counts` rows a message, the odd messages from lists of
/// rows, the even from consecutive rows (ghost slots), empty messages among them. Every message
/// is the host loop's run; scattered back into poisoned columns, exactly the rows named.
void batch_round_trip(exec::Backend b, const std::vector<std::size_t>& sizes,
                      const std::vector<std::size_t>& counts, const char* what) {
  SCOPED_TRACE(std::string(what) + (b == exec::Backend::Cpu ? ", CPU" : ", CUDA"));
  const std::size_t n_rows = 4000;
  Columns cols(b, sizes, n_rows);
  std::vector<std::uint32_t> all(n_rows);
  std::iota(all.begin(), all.end(), 0u);
  std::shuffle(all.begin(), all.end(), std::mt19937(7));
  std::vector<std::vector<std::uint32_t>> rows;
  std::vector<exec::DeviceBuffer<std::uint32_t>> drows;
  std::vector<exec::DeviceBuffer<unsigned char>> runs;
  std::vector<exec::RowMessage> msgs;
  std::size_t taken = 0, next_first = 3000; // consecutive messages from row 3000 on
  for (std::size_t m = 0; m < counts.size(); ++m) {
    const std::size_t n = counts[m];
    std::vector<std::uint32_t> r;
    exec::RowMessage msg;
    msg.n = n;
    if (m % 2) { // listed: distinct rows below 3000, in shuffled order
      for (; r.size() < n; ++taken)
        if (all[taken] < 3000)
          r.push_back(all[taken]);
    } else {
      for (std::size_t k = 0; k < n; ++k)
        r.push_back(std::uint32_t(next_first + k));
      msg.first = next_first;
      next_first += n;
    }
    drows.emplace_back(b, 0, "test.rows");
    drows.back().assign(r);
    runs.emplace_back(b, n * std::accumulate(sizes.begin(), sizes.end(), std::size_t(0)),
                      "test.run");
    runs.back().poison();
    rows.push_back(r);
    msgs.push_back(msg);
  }
  for (std::size_t m = 0; m < msgs.size(); ++m) {
    msgs[m].packed = runs[m].data();
    if (m % 2)
      msgs[m].rows = drows[m].data();
  }
  const auto refs = cols.refs(sizes);
  exec::gather_messages({b}, refs.data(), refs.size(), msgs.data(), msgs.size(), "test.pack");
  for (std::size_t m = 0; m < msgs.size(); ++m)
    EXPECT_EQ(runs[m].to_host(), packed_on_host(cols, sizes, rows[m])) << "message " << m;

  for (auto& d : cols.dev)
    d.poison();
  exec::scatter_messages({b}, refs.data(), refs.size(), msgs.data(), msgs.size(), "test.unpack");
  for (std::size_t c = 0; c < sizes.size(); ++c) {
    std::vector<unsigned char> expect(sizes[c] * n_rows, 0xFF);
    for (const auto& r : rows)
      for (std::uint32_t i : r)
        if (sizes[c] > 0) // as above: an empty column has no storage
          std::memcpy(expect.data() + i * sizes[c], cols.host[c].data() + i * sizes[c], sizes[c]);
    EXPECT_EQ(cols.dev[c].to_host(), expect) << "column " << c << " scattered";
  }
}

} // namespace

TEST(RowCopy, ARefreshsMessagesPackInOneBatch) {
  for (auto b : backends()) {
    // Two peers, six (a 2-D interior rank), 26 (3-D), and 40: more than one launch takes.
    batch_round_trip(b, {12, 12, 4}, {101, 57}, "2 messages");
    batch_round_trip(b, {24, 24, 8, 8}, {30, 0, 11, 64, 1, 9}, "6 messages, one empty");
    batch_round_trip(b, {12, 4}, std::vector<std::size_t>(26, 37), "26 messages");
    batch_round_trip(b, {12, 4}, std::vector<std::size_t>(exec::kBatchedMessages + 8, 23),
                     "40 messages");
    // Columns that are not 4-byte words: a launch a message and column, the same bytes.
    batch_round_trip(b, {12, 1, 6}, {40, 13, 7}, "odd sizes");
  }
}

TEST(RowCopy, WordColumnsPackInOneRun) {
  // A halo refresh's columns: positions and velocities (12 or 24 bytes), densities (4 or 8),
  // ids (8).
  for (auto b : backends()) {
    round_trip(b, {12, 12}, "x, v in float");
    round_trip(b, {24, 24, 8, 8}, "x, v, rho, id in double");
    round_trip(b, {4}, "one column");
  }
}

TEST(RowCopy, ManyOrOddColumnsTakeALaunchEach) {
  for (auto b : backends()) {
    // More columns than one launch takes.
    round_trip(b, std::vector<std::size_t>(exec::kPackedColumns + 3, 4), "19 columns");
    // A column of bytes (a flag) and one of 6 bytes: not 4-byte words.
    round_trip(b, {12, 1, 6, 8}, "odd sizes");
    // A zero-size column among others takes no room.
    round_trip(b, {4, 0, 8}, "an empty column");
  }
}
