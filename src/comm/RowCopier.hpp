#pragma once
// How a halo refresh or a migration reads and writes rows of the particles' columns. The host's
// copies by default; a device backend supplies its own (domain/DeviceRows), whose columns are
// device memory, packed on the device and staged through the host for an MPI transport. Knows
// no physics: columns are bytes.
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

namespace kf::comm {

/// A column of per-particle values: element k of `elem_bytes` bytes at data + k * elem_bytes.
struct Column {
  void* data = nullptr;
  std::size_t elem_bytes = 0;
};

/// A list of rows used over many calls (a halo's send list, its ghosts' slots): a copier may
/// keep its own copy in `cache` (a device copier: the list uploaded once, not at every refresh).
/// A copier's remap may leave the rows in its copy alone (`on_host` false, `rows` empty):
/// RowCopier::rows_of() brings them to the host when asked. Change the rows only through set()
/// and set_cached().
struct RowList {
  mutable std::vector<std::uint32_t> rows;
  mutable bool on_host = true;
  mutable std::shared_ptr<void> cache;
  RowList() = default;
  explicit RowList(std::vector<std::uint32_t> r) { set(std::move(r)); }
  void set(std::vector<std::uint32_t> r) {
    rows = std::move(r);
    count_ = rows.size();
    on_host = true;
    cache.reset();
  }
  /// n rows held only in a copier's copy.
  void set_cached(std::size_t n, std::shared_ptr<void> copy) {
    rows.clear();
    count_ = n;
    on_host = false;
    cache = std::move(copy);
  }
  std::size_t size() const { return count_; }

private:
  std::size_t count_ = 0;
};

/// Packed buffers (messages) are host memory, or device memory where a device copier feeds a
/// transport of device buffers (NCCL), column-major: each column's values for the rows in a run,
/// the columns in the order given (so unpacking is one copy a column). The public calls time
/// themselves (the split's packing); a backend overrides the do_ functions.
class RowCopier {
public:
  virtual ~RowCopier() = default;
  /// The messages of an exchange (one a peer) at once: outs[k] <- the rows lists[k] of each
  /// column in turn. The host packs one after another; a device backend in one launch.
  void gather(std::span<const Column> cols, std::span<const RowList> lists,
              std::span<unsigned char* const> outs);
  /// ins[k], packed as gather packs, -> counts[k] consecutive rows of each column, message after
  /// message from row `first` (ghosts in their slots, arrivals after the staying particles).
  void put(std::span<const Column> cols, std::size_t first, std::span<const std::size_t> counts,
           std::span<const unsigned char* const> ins);
  /// The same into the rows slots[o_k ..] where o_k is the sum of the counts before k.
  void scatter(std::span<const Column> cols, const RowList& slots,
               std::span<const std::size_t> counts, std::span<const unsigned char* const> ins);
  /// Of rows 0 .. n - 1 of each column, the rows `gone` (ascending) are removed and the others
  /// close up to rows 0, 1, ... in order: only the leavers' indices are passed, so a device
  /// backend finds the rows that stay where they are.
  void remove(std::span<const Column> cols, std::size_t n, std::span<const std::uint32_t> gone);
  /// Of rows 0 .. n - 1 of each column, those with keep[i] != 0 close up to rows 0, 1, ... in
  /// order; returns their count. keep: one flag a row, in the columns' memory (the backend's), so
  /// that a device backend drops many rows without their indices crossing the bus.
  std::size_t keep_flagged(std::span<const Column> cols, std::size_t n, const std::uint32_t* keep);
  /// After the rows were reordered (new_of_old: element i where row i went, in the copier's
  /// memory): each listed row becomes where it went. A device copier maps its own copy of the
  /// list on the device and leaves the host's copy to rows_of().
  void remap(RowList& list, Column new_of_old);
  /// The list new_of_old[first], ..., new_of_old[first + n - 1] (where n consecutive rows went).
  RowList remapped_range(Column new_of_old, std::size_t first, std::size_t n);
  /// A list of the n rows at `rows` (memory of the copier's kind: a list chosen on a device
  /// stays there).
  RowList adopt(const std::uint32_t* rows, std::size_t n);
  /// The list's rows in host memory (brought from the copier's copy where only it holds them).
  const std::vector<std::uint32_t>& rows_of(const RowList& list);
  /// The list's rows written at `out`, memory of the copier's kind (device memory on a device).
  void copy_rows(const RowList& list, std::uint32_t* out);
  /// Seconds spent in the calls above so far.
  double seconds() const { return seconds_; }
  /// Host memory for message `slot` of an exchange (at least `bytes`; kept and reused, its
  /// contents not): page-locked on a device backend, so the packed rows cross the bus at full
  /// speed. Valid until the next call for the same slot: one exchange at a time per copier.
  unsigned char* message(std::size_t slot, std::size_t bytes) { return do_message(slot, bytes); }

protected:
  // The host's memcpy.
  virtual void do_gather(std::span<const Column> cols, std::span<const RowList> lists,
                         std::span<unsigned char* const> outs);
  virtual void do_put(std::span<const Column> cols, std::size_t first,
                      std::span<const std::size_t> counts,
                      std::span<const unsigned char* const> ins);
  virtual void do_scatter(std::span<const Column> cols, const RowList& slots,
                          std::span<const std::size_t> counts,
                          std::span<const unsigned char* const> ins);
  virtual void do_remove(std::span<const Column> cols, std::size_t n,
                         std::span<const std::uint32_t> gone);
  virtual std::size_t do_keep_flagged(std::span<const Column> cols, std::size_t n,
                                      const std::uint32_t* keep);
  virtual unsigned char* do_message(std::size_t slot, std::size_t bytes);
  virtual void do_remap(RowList& list, Column new_of_old);
  virtual RowList do_remapped_range(Column new_of_old, std::size_t first, std::size_t n);
  /// Fills list.rows from the copier's copy (called where !list.on_host).
  virtual void do_rows_to_host(const RowList& list);
  virtual void do_copy_rows(const RowList& list, std::uint32_t* out);
  virtual RowList do_adopt(const std::uint32_t* rows, std::size_t n);

private:
  double seconds_ = 0;
  std::vector<std::vector<unsigned char>> messages_;
};

/// A host copier shared by callers that need no timing of their own (the default argument).
RowCopier& host_rows();

/// Bytes of one row over the columns.
inline std::size_t row_bytes(std::span<const Column> cols) {
  std::size_t b = 0;
  for (const Column& c : cols)
    b += c.elem_bytes;
  return b;
}

} // namespace kf::comm
