#pragma once
// Knit self-collision stage: a neighbour grid over the knit points (sorting a permutation, not
// the points), cell-ordered copies of what the pair loop reads, and the DEM force pass.
#include "kernels/grid/NeighbourGrid.hpp"
#include "kernels/grid/SkinWatch.hpp"
#include "kernels/knit/SelfContact_K.hpp"
#include "kernels/particles/KnitSet.hpp"

#include <array>
#include <optional>

namespace kf {

template <typename T>
class KnitSelfContact {
public:
  /// geo: a grid with cells no smaller than 2 * params.radius.
  /// list_capacity: allowed partners listed per point; a fuller row (a deep fold) walks its
  /// cells instead (exact, slower).
  /// windowed: for N ranks, where each sorts into a window of geo (fit_window, before any sort):
  /// the grid holds one cell until then, not the whole room's tables.
  static constexpr std::uint32_t kListCapacity = 32;
  KnitSelfContact(exec::Backend b, const GridGeometry<T>& geo, const SelfContactParams<T>& params,
                  std::uint32_t list_capacity = kListCapacity, bool windowed = false);

  /// Brings the cell-ordered copies up to date, exactly: the grid is sorted again when a point
  /// moved farther than the skin (cell - 2R) since the last sort (until then every pair within 2R
  /// is still found in the 27 cells around a point, and only positions and velocities are
  /// gathered again through the kept permutation). Reads the motion on the host (waits).
  void sync(const exec::Exec& ex, KnitSet<T>& set);
  /// Once per fluid step, before its substeps: sorts the grid if a point is so far from its
  /// sorted position that `motion` (a bound on how far a point will move over the step, from
  /// its speed and acceleration) could take it past the skin. When twice the motion fits in the
  /// skin, the step's update() calls wait for nothing: the motion is watched on the device and a
  /// substep whose points did cross the skin after all sums over all pairs instead (exact, slow,
  /// counted in stale_steps()). Otherwise update() is sync(). The motion is read on the host
  /// only when the motion expected since the last reading could have used up the skin.
  void begin_step(const exec::Exec& ex, KnitSet<T>& set, T motion);
  /// The points' masses change between steps (the knit absorbs fluid): each step then takes
  /// them anew, not only at a sort.
  void set_masses_vary(bool vary) { masses_vary_ = vary; }
  /// Call after the points moved, before add_forces.
  void update(const exec::Exec& ex, KnitSet<T>& set);
  /// update() for a pass that gathers the copies itself, with another structure's
  /// (observe_gather of two WatchedCopies): the copies and watch to fill, or none where this
  /// step's checks are on the host (then it has synced them itself).
  WatchedCopies<T> update_copies(const exec::Exec& ex, KnitSet<T>& set);
  /// On N ranks (the set holds owned points, then ghosts): the grid's ties go by id (within a
  /// sort key, as the one-rank run's set, which is in id order), so every pair list is the
  /// one-rank run's; the host's motion readings are the job's (job_max). add_forces and stats
  /// cover the first `active` points (the owned ones).
  void distribute(std::function<T(T)> job_max) {
    ties_by_id_ = true;
    watch_.set_job_max(std::move(job_max));
  }
  void set_active(std::size_t active) { active_ = active; }
  /// On N ranks: the grid over the cells lo .. hi of the whole grid (NeighbourGrid::within), a
  /// rank's region and its ghosts' reach, where the whole room's cells cost every rank its
  /// tables; the next sort (restore) sorts into it. A point inside keeps the cell it has on the
  /// whole grid, so the lists are the one-rank run's; one outside clamps to an edge cell.
  void fit_window(std::array<int, 3> lo, std::array<int, 3> hi);
  /// The grid over the whole room this one was made with (its cells are the window's).
  const GridGeometry<T>& whole_grid() const { return whole_; }
  const GridGeometry<T>& grid() const { return grid_->geometry(); }
  /// Grid sorts so far (for the benchmark and the tests).
  std::uint64_t sorts() const { return sorts_; }
  /// Readings that found device-watched substeps past the skin (they summed over all pairs).
  std::uint64_t stale_steps() const { return stale_steps_; }
  /// Whether this step's update() calls wait for the host's check (set by begin_step).
  bool checks_on_host() const { return host_checks_; }
  /// a += self-contact force / m on every free point (a already holds springs and gravity).
  void add_forces(const exec::Exec& ex, KnitSet<T>& set) const;
  /// The pass's evaluator, for a pass that adds it to others (KnitPointForces), over the first
  /// active(set) points.
  SelfContactEvaluator<T> evaluator(KnitSet<T>& set) const;
  /// Contacts, penalty energy and closest approach at the last update.
  SelfContactStats stats(const exec::Exec& ex, KnitSet<T>& set) const;

  const SelfContactParams<T>& params() const { return params_; }
  /// The grid's cell edge and the watch's skin (a pair list reaches a cell edge at the sort).
  T cell() const { return cell_; }
  T skin() const { return watch_.skin(); }
  std::size_t bytes() const;

  /// Restart: the positions of the last sort and the watch's record (snapshot state).
  typename SkinWatch<T>::State state() const { return watch_.state(); }
  /// Sorts the grid for the state's positions (as the run that wrote it last did) and takes its
  /// watch; set holds the restored points.
  void restore(const exec::Exec& ex, KnitSet<T>& set, const typename SkinWatch<T>::State& s);

private:
  SortedKnitView<T> sorted() const;
  /// Sorted slot -> set index.
  const exec::DeviceBuffer<std::uint32_t>& perm() const { return grid_->permutation(); }
  std::size_t active(const KnitSet<T>& set) const { return std::min(active_, set.size()); }
  SelfContactParams<T> params_;
  GridGeometry<T> whole_;
  std::optional<NeighbourGrid<T>> grid_;
  exec::DeviceBuffer<Vec3<T>> x_, v_, rest_;
  exec::DeviceBuffer<T> m_;
  exec::DeviceBuffer<std::uint16_t> piece_;
  exec::DeviceBuffer<std::uint64_t> id_;
  // Sorts the grid for the positions `at` (set.x, or a restart's), gathers every cell-ordered
  // copy (x from `at`, v) and builds the lists.
  void sort(const exec::Exec& ex, KnitSet<T>& set) { sort(ex, set, set.x); }
  void sort(const exec::Exec& ex, KnitSet<T>& set, const exec::DeviceBuffer<Vec3<T>>& at);
  void gather_motion(const exec::Exec& ex, KnitSet<T>& set);
  SkinWatch<T> watch_; // motion since the last sort: half the cell's margin over 2R
  // Per point, the sorted points it may touch (not excluded) within a cell edge at the sort: a
  // pair within 2R later, each point at most half the margin from where it was sorted, was
  // within 2R + margin = a cell edge then. A knit lying flat lists almost nothing.
  NeighbourList<T> list_;
  T cell_;
  std::uint32_t list_capacity_;
  bool host_checks_ = true;
  bool masses_vary_ = false;
  std::uint64_t sorts_ = 0, stale_steps_ = 0;
  // N ranks (distribute): ties in the sort by id; the owned points' count.
  bool ties_by_id_ = false;
  std::size_t active_ = std::size_t(-1);
};

} // namespace kf
