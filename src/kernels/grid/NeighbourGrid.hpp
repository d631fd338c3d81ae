#pragma once
#include "kernels/exec/Algorithms.hpp"
#include "kernels/exec/PendingRead.hpp"
#include "kernels/grid/GridGeometry.hpp"

#include <array>
#include <limits>
#include <optional>

namespace kf {

/// Squared displacement of point i since the grid was sorted; a NaN reads as the largest value
/// (a max-reduction would drop it). A named functor, not a device lambda: nvcc's host-device
/// lambda wrappers in an inline function shared by several translation units called a null
/// function on the CPU backend of the CUDA build.
template <typename T>
struct SquaredDisplacement {
  const Vec3<T>* x;
  const Vec3<T>* x0;
  KF_HD KF_INLINE T operator()(std::size_t i) const {
    const T d2 = norm2(x[i] - x0[i]);
    return d2 == d2 ? d2 : std::numeric_limits<T>::max();
  }
};

/// The box a point must lie in to keep its place in a sort (NeighbourGrid::build_keeping). A
/// NaN coordinate counts as inside: the point stays for the step-size check to report. Where
/// `rows` is given, point i also needs rows[i] != 0 (on N ranks: the rows a rebuild left in
/// place that no longer belong here, dropped by the sort instead of a compaction before it).
template <typename T>
struct KeepBox {
  Vec3<T> lo, hi;
  const std::uint32_t* rows = nullptr;
  KF_HD KF_INLINE bool outside(const Vec3<T>& q) const {
    return q.x < lo.x || q.x > hi.x || q.y < lo.y || q.y > hi.y || q.z < lo.z || q.z > hi.z;
  }
  KF_HD KF_INLINE bool dropped(std::size_t i, const Vec3<T>& q) const {
    return outside(q) || (rows != nullptr && rows[i] == 0);
  }
  /// Every point inside: only the rows' flags choose.
  static KeepBox everywhere(const std::uint32_t* rows) {
    const T big = std::numeric_limits<T>::max();
    return {{-big, -big, -big}, {big, big, big}, rows};
  }
};

/// Sorts one particle set by cell (rows along x, Morton order over y, z; optionally by sub-cell
/// within each cell) and keeps the cell tables for neighbour loops. After build(),
/// permutation()[i] is the old index of the particle now at i; the owner reorders its fields
/// with it so that positions and tables agree.
template <typename T>
class NeighbourGrid {
public:
  /// span: cells searched on each side of a particle's cell (the interaction radius is span
  /// cell edges; see CellView). order_levels (0-2): within each cell the particles also go in
  /// Morton order of 2^levels sub-cells a side, as far as the sort key's 32 bits allow (fewer
  /// levels on a grid of more than 2^(32 - 3 levels) cells); neighbour passes that gather by
  /// particle then read nearby memory for nearby lanes. Cells and their ranges do not change.
  /// name: its buffers' labels ("fluid.grid": "fluid.grid.start", ...; exec::peak_by_label).
  NeighbourGrid(exec::Backend b, const GridGeometry<T>& geo, int span = 1, int order_levels = 0,
                const char* name = "grid");

  /// Grid covering [lo, hi] with cells of edge `cell` plus `pad` cells of padding on every side.
  static GridGeometry<T> cover(const Vec3d& lo, const Vec3d& hi, double cell, int pad = 1);

  /// The cells lo .. hi (indices on `whole`'s own whole grid, inclusive, clamped to `whole`) as a
  /// grid of their own: a rank's region. A point inside it has the cell and sub-cell it has on
  /// `whole`, so sorts and walks over it visit the same particles in the same order; a point
  /// outside falls into the nearest edge cell, as one outside `whole` does there. A walk from
  /// such a point still meets every particle sorted into the window within its reach
  /// (clamping a cell index towards the window only brings it nearer the cells inside).
  static GridGeometry<T> within(const GridGeometry<T>& whole, std::array<int, 3> lo,
                                std::array<int, 3> hi);

  /// tie_id (optional, per point): points sharing a sort key (one sub-cell) go in ascending id,
  /// not in their input order. The input order is the run's history; on N ranks it differs
  /// from one rank's (migrants arrive at the end), and a tie then sums a cell's particles in
  /// another order: by id, every partition orders a cell as one rank does.
  void build(const exec::Exec& ex, const Vec3<T>* x, std::size_t n,
             const std::uint64_t* tie_id = nullptr);
  /// build(), with the points outside `keep` sorted after all the others (in their order) and
  /// in no cell. The count inside is read back behind the sort: kept() waits for it, so the
  /// owner can queue its reorder first. permutation() lists all n until drop_outside(kept)
  /// leaves the first kept (one sort for what was a compaction and a sort).
  void build_keeping(const exec::Exec& ex, const Vec3<T>* x, std::size_t n, const KeepBox<T>& keep,
                     const std::uint64_t* tie_id = nullptr);
  std::size_t kept();
  void drop_outside(std::size_t kept);
  /// Levels of sub-cell order in use (order_levels, or fewer where the key lacks bits).
  int order_levels() const { return levels_; }
  /// Bits of a cell's rank on a grid of `cells` cells (at least 1), and the levels of sub-cell
  /// order (at most order_levels) that fit beside them in the 32-bit sort key.
  static int rank_bits(std::uint32_t cells);
  static int usable_order_levels(std::uint32_t cells, int order_levels);
  /// flag[linear cell index] = 1 when some particle of this grid lies in the cells a neighbour
  /// loop from that cell visits, else 0: a point of another set (on a grid of the same
  /// geometry) in a 0 cell has no candidates here and can skip the loop. After build().
  void occupied_around(const exec::Exec& ex, exec::DeviceBuffer<std::uint8_t>& flag) const;
  const exec::DeviceBuffer<std::uint32_t>& permutation() const { return perm_; }
  CellView<T> view() const { return {geo_, rank_.data(), start_.data(), end_.data(), span_}; }
  const GridGeometry<T>& geometry() const { return geo_; }
  std::size_t bytes() const;

private:
  void sort(const exec::Exec& ex, const Vec3<T>* x, std::size_t n, const KeepBox<T>* keep,
            const std::uint64_t* tie_id);

  GridGeometry<T> geo_;
  int span_ = 1;
  // Of the sort key: the cell's rank (one rank more than the cells: points outside a KeepBox
  // take rank cells()), then 3 levels_ bits of sub-cell.
  int key_bits_ = 1;
  int levels_ = 0;
  bool cleared_ = false; // start/end zeroed once; later builds clear only the cells last used
  exec::DeviceBuffer<std::uint32_t> rank_, start_, end_, keys_, perm_;
  exec::DeviceBuffer<std::uint32_t> kept_;                    // build_keeping's count
  std::optional<exec::PendingRead<std::uint32_t>> kept_read_; // opened by build_keeping
  std::size_t kept_count_ = 0;
};

} // namespace kf
