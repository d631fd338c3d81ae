#pragma once
// The transpose of a pair list: for each target, the source rows whose lists hold it. The
// knit-fluid coupling lists the knit points near each fluid particle once a step (its fluid
// side reads them); the knit side, which needs the same pairs seen from the knit, walked the
// fluid grid's 27 cells around each point in every substep instead, 4.5 of the pour's 20 s on
// an H200 (docs/PERFORMANCE.md, P10). Transposed once a step, the pairs serve every substep.
//
// A target's row holds the pairs' slots in the source list (ListView::slot), so that a value
// kept per pair by the source side's pass (the coupling's pair force) is read back by the
// target's, not computed twice.
//
// Built in three passes with no read on the host: the counts zeroed; each listed pair appended
// to its target's row by an atomic count (in no fixed order); each row then put in ascending
// order of source row (a rank sort: an entry's place is the number of entries of lower rows;
// a target is listed once a row). That order is fixed on any thread count and, for the fluid
// sorted by cell and id on every rank, on any rank count.
#include "kernels/exec/Algorithms.hpp"
#include "kernels/grid/NeighbourList.hpp"

namespace kf {

namespace transpose_detail {

/// Appends source row j's slots to their targets' rows (unordered), a group of lanes a row.
template <typename T>
struct Fill {
  ListView<T> src;
  const std::uint32_t* active; // nullptr: every source row
  const std::uint32_t* map;    // a source entry -> its target (nullptr: the entry itself)
  std::uint32_t* count;        // per target, then the incomplete word
  std::uint32_t* incomplete;
  const std::uint32_t* sources; // a count on the device of the rows meant (nullptr: src.rows)
  ListSink unsorted;
  std::uint32_t* unsorted_row; // beside each unsorted slot: its source row (the sort's key)

  KF_HD void operator()(std::size_t j, exec::Lanes g = {}) const {
    // More rows meant than listed: the rows past the room were never listed (their pairs
    // unknown). Here, not in a launch of its own: one thread's word a build cost the pour's
    // whole run 31 ms of launches on an H100.
    if (j == 0 && g.lane == 0 && sources && *sources > src.rows)
      exec::atomic_fetch_add(incomplete, 1u);
    if (active && !active[j])
      return;
    const std::uint32_t c = src.count[j];
    if (c > src.capacity) { // its pairs are not all listed: no target row is known complete
      if (g.lane == 0)
        exec::atomic_fetch_add(incomplete, 1u);
      return;
    }
    for (std::uint32_t k = g.lane; k < c; k += g.size) {
      const std::uint32_t e = src.list[src.slot(j, k)];
      const std::uint32_t t = map ? map[e] : e;
      const std::uint32_t s = exec::atomic_fetch_add(count + t, 1u);
      if (s < unsorted.capacity) {
        *unsorted.slot(t, s) = static_cast<std::uint32_t>(src.slot(j, k));
        unsorted_row[unsorted.slot(t, s) - unsorted.list] = static_cast<std::uint32_t>(j);
      }
    }
  }
};

/// Puts target row t in ascending order of source row: each entry goes to the slot given by the
/// number of entries from lower rows (no two from one row). A row over the capacity is left:
/// its user walks instead (ListView::complete).
template <typename T>
struct Sort {
  const std::uint32_t* count;
  ListView<T> unsorted;
  const std::uint32_t* unsorted_row; // the keys, beside unsorted's slots (Fill)
  ListSink sorted;

  KF_HD void operator()(std::size_t t, exec::Lanes g = {}) const {
    const std::uint32_t c = count[t];
    if (c > sorted.capacity)
      return;
    for (std::uint32_t k = g.lane; k < c; k += g.size) {
      const std::uint32_t row = unsorted_row[unsorted.slot(t, k)];
      std::uint32_t below = 0;
      for (std::uint32_t m = 0; m < c; ++m)
        below += unsorted_row[unsorted.slot(t, m)] < row ? 1u : 0u;
      *sorted.slot(t, below) = unsorted.list[unsorted.slot(t, k)];
    }
  }
};

} // namespace transpose_detail

template <typename T>
class TransposedList {
public:
  /// name: its buffers' labels ("coupling.knit_rows": "coupling.knit_rows.list", ...).
  explicit TransposedList(exec::Backend b, const char* name = "transpose");

  /// Rows for n targets: row t lists, in ascending order of source row, the slot src.slot(j, k)
  /// of every source row j (with active[j] set, or all when active is null) whose entry k is
  /// e with map[e] == t (e == t without a map). A row of more than `capacity` pairs keeps only
  /// its count (ListView::complete is false there); a source row that overflowed its own
  /// capacity leaves its pairs unknown and sets *incomplete() (the whole transpose is then not
  /// to be read). `sources`, where given, is a count on the device of the source rows meant:
  /// when it is over src.rows, the rows past the list's room were never listed, and the
  /// transpose is marked incomplete too. The source list's slots must fit in 32 bits.
  void build(const exec::Exec& ex, const ListView<T>& src, const std::uint32_t* active,
             const std::uint32_t* map, std::size_t n, std::uint32_t capacity,
             const std::uint32_t* sources = nullptr);
  ListView<T> view() const { return {count_.data(), list_.data(), capacity_, rows_}; }
  /// Each target's pair count (its first rows(); a row over the capacity counts every pair).
  const exec::DeviceBuffer<std::uint32_t>& counts() const { return count_; }
  std::size_t rows() const { return rows_; }
  /// Device word: nonzero when some source row's pairs were not all listed (build).
  const std::uint32_t* incomplete() const { return count_.data() + rows_; }
  std::size_t bytes() const {
    return count_.capacity_bytes() + unsorted_.capacity_bytes() + unsorted_row_.capacity_bytes() +
           list_.capacity_bytes();
  }

private:
  exec::DeviceBuffer<std::uint32_t> count_, unsorted_, unsorted_row_, list_;
  std::uint32_t capacity_ = 0;
  std::size_t rows_ = 0;
};

} // namespace kf
