#pragma once
// The springs of the knit mesh, stored per point: every spring appears in the rows of both its
// ends, so each point gathers its own force (no atomics, deterministic sums, the same code on both
// backends).
#include "core/Vec3.hpp"
#include "kernels/exec/Algorithms.hpp"
#include "kernels/exec/HostReadable.hpp"
#include "kernels/knit/RowLayout.hpp"

#include <cstdint>
#include <vector>

namespace kf {

/// Spring families of the three-layer knit model (paper Fig. 1a).
enum class SpringKind : std::uint8_t {
  Stretch,        // neighbours along a wale or a course, within a layer
  Shear,          // quad diagonals, within a layer
  Bend,           // every second point along a wale or a course, within a layer
  VolumeStraight, // the same mesh node in adjacent layers (keeps the thickness)
  VolumeDiagonal, // a node and the neighbours of its twin in the adjacent layer (resists layer
                  // shear)
};
inline constexpr int kSpringKinds = 5;

/// One spring between points i and j (host side, built once from the rest mesh).
struct Spring {
  std::uint32_t i = 0, j = 0;
  double rest = 0; // rest length [m]
  double k = 0;    // stiffness [N/m]
  double c = 0;    // damping along the spring [N s/m]
  SpringKind kind = SpringKind::Stretch;
};

/// One end's view of a spring: the point at the other end and the spring's constants.
template <typename T>
struct SpringEntry {
  std::uint32_t other = 0;
  T rest = T(0), k = T(0), c = T(0);
};

/// Point i's e-th spring is entry[rows.at(e, i)], e < count[i]: slot-major (ELL) on the GPU, so
/// the lanes of a warp, one point each, read adjacent entries (compressed rows had each lane read
/// its own row: a cache line per lane per spring); row-major on the CPU (RowLayout).
template <typename T>
struct SpringView {
  const std::uint32_t* count;
  const SpringEntry<T>* entry;
  RowLayout rows;

  /// f(entry) for point i's springs (with lanes: every stride-th from `lane` on).
  template <typename F>
  KF_HD KF_INLINE void for_each_spring(std::size_t i, F&& f, std::uint32_t lane = 0,
                                       std::uint32_t stride = 1) const {
    const std::uint32_t c = count[i];
    for (std::uint32_t e = lane; e < c; e += stride)
      f(entry[rows.at(e, i)]);
  }
};

template <typename T>
class SpringTopology {
public:
  /// A rank's points' rows on N ranks, in its points' order, their other ends mesh indices
  /// (= ids): kept on the host (HostReadable), a point's row in one piece (row-major, read once
  /// across the bus), so that no GPU holds the knit's springs twice; they migrate with their
  /// points (KnitHalo), and each choice of ghosts localizes them (localize).
  struct HostRows {
    exec::HostReadable<std::uint32_t> count;
    exec::HostReadable<SpringEntry<T>> entry;
    std::uint32_t width = 0;
    std::size_t springs = 0; // in the whole mesh
    std::vector<std::size_t> by_kind;
    std::size_t points() const { return count.size(); }
    RowLayout rows() const { return {1, width}; }
    SpringView<T> view() const { return {count.data(), entry.data(), rows()}; }
    /// n rows, the first kept (a migration's).
    void resize(std::size_t n) {
      count.resize(n);
      entry.resize(n * width);
    }
  };
  /// The rows of points ids[0..] (row k: point ids[k]'s springs in the list's order) from a list
  /// over n_points points that holds every spring of those points (others are passed over); the
  /// row width is the widest of these rows, at least `width`. For kernels of backend b.
  static HostRows host_rows(exec::Backend b, const std::vector<Spring>& springs,
                            std::size_t n_points, const std::vector<std::uint64_t>& ids,
                            std::uint32_t width = 0);

  explicit SpringTopology(exec::Backend b);
  /// Builds the rows from a spring list over n_points points (each row in the list's order);
  /// rejects i == j and indices >= n.
  void build(const std::vector<Spring>& springs, std::size_t n_points);
  /// On N ranks, from the rank's rows (HostRows, row k the k-th local point's, over mesh
  /// indices = ids): rows for the first `owned` local points, each whole, in its order, the
  /// other ends mapped to local indices (local_of_id, by id; every partner of an owned point
  /// present). The ghosts after them have no rows (no pass reads them: the table is the owned
  /// points' only). On the backend: a gather, where filtering the mesh's spring list on the host
  /// cost 20-25 ms a choice of ghosts.
  void localize(const exec::Exec& ex, const HostRows& rows, const std::uint32_t* local_of_id,
                std::size_t owned);
  /// The points with rows (all of them; on N ranks the owned ones).
  std::size_t points() const { return count_.size(); }
  SpringView<T> view() const;
  /// The springs built from (localized: the mesh's).
  std::size_t springs() const { return springs_; }
  std::size_t bytes() const;
  /// Springs per kind, for `plan` and the summary.
  const std::vector<std::size_t>& count_by_kind() const { return by_kind_; }

private:
  exec::DeviceBuffer<std::uint32_t> count_;
  exec::DeviceBuffer<SpringEntry<T>> entry_;
  std::size_t springs_ = 0;
  std::uint32_t width_ = 0; // the most springs of one point
  /// Where the rows sit: the backend's layout for these points and width.
  RowLayout rows() const { return RowLayout::for_backend(count_.backend(), count_.size(), width_); }
  std::vector<std::size_t> by_kind_;
};

} // namespace kf
