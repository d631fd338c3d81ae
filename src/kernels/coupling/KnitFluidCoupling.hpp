#pragma once
// Knit-fluid coupling state and stages (paper §5; docs/PHYSICS.md "Coupling"). Per fluid step:
// begin_step() takes the knit's saturation and capillary pressure from the fluid there (Eq.
// 9-11) and clears the fluid's impulses; inside every knit substep add_forces() adds the pair
// forces to the knit's accelerations and the same forces, times their share of the step, to
// the fluid's impulses; after the knit's step apply_impulses() hands them to the fluid. The knit
// feels the contact at its substep, the fluid its exact opposite, summed over the same substeps.
#include "kernels/coupling/Coupling_K.hpp"
#include "kernels/exec/Algorithms.hpp"
#include "kernels/grid/NeighbourGrid.hpp"
#include "kernels/grid/NeighbourList.hpp"
#include "kernels/grid/SkinWatch.hpp"
#include "kernels/grid/TransposedList.hpp"
#include "kernels/knit/KnitForces_K.hpp"
#include "kernels/particles/FluidSet.hpp"
#include "kernels/particles/KnitSet.hpp"

#include "core/SolverOptions.hpp"

#include <algorithm>
#include <array>
#include <functional>
#include <limits>
#include <optional>

namespace kf {

/// The fluid as the coupling reads it: positions, velocities, masses, densities in the fluid
/// grid's order, and that grid.
template <typename T>
struct FluidSide {
  FluidView<T> f;
  CellView<T> cells;
  // NeighbourGrid::occupied_around of `cells` (null: unknown): a knit point whose cell has no
  // fluid around skips its walk, which would find nothing (most of a sheet is dry).
  const std::uint8_t* near = nullptr;
};

/// Where the coupling's per-step lists may be built for the fluid, so that they last over steps:
/// the positions the fluid's own lists were built for (SphLists::listed_x, in the fluid's order
/// now), the count of the fluid's sorts that gave that order, and a bound on every particle's
/// displacement since (SphLists::displacement_bound). While it stays within a watch skin, the
/// lists built for x0 hold every pair (docs/ARCHITECTURE.md "Knit-fluid coupling on the GPU").
/// Null x0: the lists are built for the positions now, every step.
template <typename T>
struct FluidAnchor {
  const Vec3<T>* x0 = nullptr;
  std::uint64_t sorts = 0;
  T moved = std::numeric_limits<T>::infinity();
};

struct CouplingStats {
  std::uint64_t contacts = 0; // fluid-knit pairs in contact
  double energy = 0;          // their penalty energy 1/2 k u^2 [J]
  double absorbed_mass = 0;   // sum over knit points of m_fluid [kg]
  double max_saturation = 0, mean_saturation = 0;
  std::uint64_t wet_points = 0; // knit points with s > 0.01
};

/// The mass-conserving model's absorbed mass and capacity per knit point (both null: the
/// paper's model, saturation from the fluid around).
template <typename T>
struct PoreMass {
  const T* absorbed = nullptr;
  const T* capacity = nullptr;
};

template <typename T>
class KnitFluidCoupling {
public:
  /// grid: a geometry covering the domain with cells larger than the coupling's reach r; the
  /// margin (cell - r) is split into the lists' skin (2/3) and the grid's (1/3).
  /// list_capacity: knit points listed per fluid particle; a fuller row walks its cells (exact,
  /// slower). A sheet of three layers holds ~31 points within a reach of 2 fluid spacings, ~55
  /// within the list's radius. knit_capacity: fluid particles listed per knit point (0: the
  /// same); a fuller point walks the fluid grid's cells. A point in water on both sides has
  /// ~80 within the list's radius.
  KnitFluidCoupling(exec::Backend b, KernelType kernel, const CouplingParams<T>& params,
                    const GridGeometry<T>& grid, std::uint32_t list_capacity = kListCapacity,
                    std::uint32_t knit_capacity = 0);

  /// Saturation, capillary pressure and absorbed mass of every knit point (when capillary), the
  /// knit grid sorted again if a point moved farther than its skin, fluid impulses zeroed.
  /// With pores (the mass-conserving model) s = absorbed / capacity and the
  /// absorbed fluid's weight is already in the knit's mass; else s comes from the fluid around.
  /// motion: how far a knit point may move over the coming step (an estimate, from its speed and
  /// acceleration). While the motion expected since the last reading leaves the skin unused,
  /// the knit grid's staleness is not read on the host: the substeps watch the motion on the
  /// device and the fluid side sums over all knit points if the skin was crossed after all.
  /// share: called after the knit's saturation, capillary pressure and wet mass are computed
  /// (on N ranks the ghosts take their owners' values there).
  /// anchor: the fluid positions to build the lists for (FluidAnchor); lists built for an
  /// anchor are kept while its sorts, its bound and the knit grid's sort allow.
  void begin_step(const exec::Exec& ex, KnitSet<T>& knit, const FluidSide<T>& fluid,
                  PoreMass<T> pores = {}, T motion = std::numeric_limits<T>::infinity(),
                  const std::function<void()>& share = {}, FluidAnchor<T> anchor = {});
  /// begin_step's first part alone: the knit's saturation, capillary pressure and wet mass from
  /// the state now (then share), the grid and lists untouched. For snapshots and diagnostics
  /// before a step where the knit's points changed (a restart shares them out anew on N ranks);
  /// the next begin_step computes the same values again.
  void update_saturation(const exec::Exec& ex, KnitSet<T>& knit, const FluidSide<T>& fluid,
                         PoreMass<T> pores = {}, const std::function<void()>& share = {});
  /// begin_step's second part: the knit grid (sorted when the knit may pass its skin over a
  /// step of `motion`), the sorted wet mass and pressure, the impulses cleared, the lists (kept
  /// for an anchor while they hold). Apart so that the host may wait for `motion` while the
  /// saturation's passes run.
  void begin_lists(const exec::Exec& ex, KnitSet<T>& knit, const FluidSide<T>& fluid, T motion,
                   FluidAnchor<T> anchor = {});
  /// On N ranks (the knit set holds owned points, then ghosts): the knit grid's ties go by id,
  /// so each fluid particle's knit candidates come in the one-rank run's order; the host's
  /// motion readings are the job's; the knit-side passes and stats cover the first `active`
  /// points (the owned ones).
  void distribute(std::function<T(T)> job_max) {
    ties_by_id_ = true;
    watch_.set_job_max(std::move(job_max));
  }
  void set_active(std::size_t active) { active_ = active; }
  /// The per-knit-point values begin_step computes (saturation, capillary pressure, wet mass),
  /// for the ghosts' refresh.
  std::array<exec::DeviceBuffer<T>*, 3> knit_values() {
    return {&saturation_, &pressure_, &fluid_mass_};
  }
  /// Knit a += coupling / m; fluid impulse += weight * (the opposite forces). With `own`, the
  /// knit's own forces in the same knit pass: a = (own + coupling) / m + g (knit_forces_with);
  /// `with`: another structure's copies of the knit, gathered in the pass that gathers this
  /// one's (the self-contact's, which `own` reads).
  void add_forces(const exec::Exec& ex, KnitSet<T>& knit, const FluidSide<T>& fluid, T weight,
                  const KnitForceTerms<T>* own = nullptr, const WatchedCopies<T>& with = {});
  /// Fluid v += impulse / m.
  void apply_impulses(const exec::Exec& ex, FluidView<T> f);

  CouplingStats stats(const exec::Exec& ex, KnitSet<T>& knit, const FluidSide<T>& fluid);
  const CouplingParams<T>& params() const { return params_; }
  /// The knit grid's cell edge and its watch's skin (a fluid particle's candidates lie within
  /// two cells a side).
  T cell() const { return cell_; }
  T skin() const { return watch_.skin(); }
  /// How far the knit may move from where its grid was sorted before a fluid particle's walk of
  /// its 27 cells may miss a pair: the cell's margin over the reach (three watch skins).
  T walk_margin() const { return cell_ - coupling_reach(params_); }
  const exec::DeviceBuffer<T>& saturation() const { return saturation_; }
  const exec::DeviceBuffer<T>& fluid_mass() const { return fluid_mass_; }
  std::size_t bytes() const;

  /// Sorts the knit grid again if a point moved past the skin (reads the motion on the host).
  void sort_knit(const exec::Exec& ex, KnitSet<T>& knit);
  /// Knit grid sorts so far.
  std::uint64_t sorts() const { return sorts_; }
  /// What it holds once its lists are built (the first begin_step; `knitflow plan`), as the
  /// constructor's capacities make it: the grid's tables over `grid`, bytes a fluid particle
  /// and a knit point, and bytes a row of the lists (a near fluid particle: its knit points and
  /// their pair forces, most of it; rows for the near ones and a quarter more).
  struct Footprint {
    std::size_t grid = 0, per_fluid = 0, per_knit = 0, per_row = 0;
    std::size_t bytes(std::size_t fluid, std::size_t knit, std::size_t near) const {
      return grid + per_fluid * fluid + per_knit * knit + per_row * rows_for(near, fluid);
    }
  };
  /// The most fluid particles near a knit at `knit_x` (`knit` points, host side): those in the
  /// knit's cells of `grid` and the cells around them, at the fluid's lattice `spacing` (5% more
  /// for its compression). An estimate for plan: the knit moves (a sheet keeps its area).
  static std::size_t near_bound(const GridGeometry<T>& grid, const Vec3<T>* knit_x,
                                std::size_t knit, double spacing);
  /// Rows held for `near` near fluid particles of `fluid`: a quarter more, to grow into, but
  /// never more than the fluid (a build's near particles are some of it).
  static constexpr std::size_t rows_for(std::size_t near, std::size_t fluid) {
    return std::min(near + near / 4 + 64, fluid);
  }
  /// Near fluid particles at the build before the last (its count read behind it), or at the
  /// first build.
  std::uint32_t near_particles() const { return last_near_; }
  static Footprint footprint(const GridGeometry<T>& grid,
                             std::uint32_t list_capacity = kListCapacity,
                             std::uint32_t knit_capacity = 0);
  static constexpr std::uint32_t kListCapacity = 96;

  /// The per-step lists' builds so far (begin_step; fewer than its calls where an anchor kept
  /// them).
  std::uint64_t list_builds() const { return list_builds_; }
  /// How far a fluid particle may be from where the near flags were taken for it (the anchor's
  /// budget, a watch skin, while the lists are an anchor's; else 0).
  T flag_slack() const { return flag_slack_; }
  /// The knit grid sorted for the current positions and the sorted positions gathered.
  void sync_knit(const exec::Exec& ex, KnitSet<T>& knit);
  const NeighbourGrid<T>& knit_grid() const { return grid_; }
  /// The pairs of the step per knit point (begin_step): its side's rows.
  const TransposedList<T>& knit_rows() const { return knit_rows_; }
  /// The set's index of the point in each of the grid's slots.
  const exec::DeviceBuffer<std::uint32_t>& perm() const { return grid_.permutation(); }
  const exec::DeviceBuffer<Vec3<T>>& sorted_x() const { return x_; }
  /// begin_step's flags (1: a knit point in the particle's 27 knit-grid cells then), while the
  /// fluid still holds the n particles it flagged in that order (else null).
  const std::uint32_t* near_flags(std::size_t n) const {
    return near_flag_.size() == n ? near_flag_.data() : nullptr;
  }
  /// Flags the fluid particles at x (n of them) with a knit point in their knit-grid cells
  /// (public: nvcc's device lambdas may not live in private members).
  void find_fluid_near_knit(const exec::Exec& ex, const Vec3<T>* x, std::size_t n);

  /// Restart: the knit's positions at the grid's last sort and the watch's record (snapshot
  /// state; empty positions before the first begin_step).
  typename SkinWatch<T>::State state() const { return watch_.state(); }
  /// Sorts the knit grid for the state's positions, as the run that wrote it last did, and
  /// takes its watch (the next begin_step then sorts when that run's did).
  void restore(const exec::Exec& ex, KnitSet<T>& knit, const typename SkinWatch<T>::State& s);

private:
  KernelType kernel_;
  bool conserving_ = false;
  CouplingParams<T> params_;
  void sort_now(const exec::Exec& ex, KnitSet<T>& knit) { sort_now(ex, knit, knit.x); }
  void sort_now(const exec::Exec& ex, KnitSet<T>& knit, const exec::DeviceBuffer<Vec3<T>>& at);
  NeighbourGrid<T> grid_;
  SkinWatch<T> watch_; // knit motion since the grid's sort
  std::uint64_t sorts_ = 0;
  exec::DeviceBuffer<T> saturation_, pressure_, fluid_mass_; // knit order
  exec::DeviceBuffer<Vec3<T>> x_, v_;                        // knit, grid order
  exec::DeviceBuffer<Vec3<T>> xs_;      // knit, grid order, where the grid was sorted: the lists
  exec::DeviceBuffer<T> m_, p_;         // knit, grid order
  exec::DeviceBuffer<Vec3<T>> impulse_; // fluid order
  // 1 for the fluid particles with a knit point in their 27 knit-grid cells, found once per step
  // (begin_step): the fluid is held still through the knit's substeps and the knit grid is not
  // sorted between them, so only these can feel the knit (while the skin holds). Flags, which
  // the passes over the fluid read where they are; the lists' rows are made from them below.
  exec::DeviceBuffer<std::uint32_t> near_flag_;
  // The near particles' rows, in the fluid's order: each one's row (an exclusive scan of the
  // flags), and per row its particle's position and whether it is one (rows past the count are
  // not). The count stays on the device: the host reads it behind the build, and the next build
  // holds rows for it and a quarter more. A build with more near particles than rows lists the
  // first; the rest walk their cells, and the knit's side walks too (the transpose marked
  // incomplete).
  exec::DeviceBuffer<std::uint32_t> row_of_, row_active_, near_count_;
  exec::DeviceBuffer<Vec3<T>> row_x_;
  exec::PendingRead<std::uint32_t> near_read_;
  std::size_t rows_ = 0;
  bool rows_sized_ = false; // the first build waits for its count
  void size_rows(const exec::Exec& ex, std::size_t n);
  // For each near fluid particle's row, the knit points within reach + list_skin_ of it, built
  // once per step; valid while no knit point moved farther than the watch's skin since the
  // grid's sort (docs/ARCHITECTURE.md "Knit-fluid coupling on the GPU" derives the skins).
  NeighbourList<T> list_;
  // list_ transposed: per knit point (the set's order), the slots of the fluid rows that hold
  // it, in the fluid's order; its side of each substep sums the forces the fluid side kept per
  // slot (pair_force_) instead of walking the fluid grid and computing them again.
  TransposedList<T> knit_rows_;
  exec::DeviceBuffer<Vec3<T>> pair_force_;
  T list_skin_;
  std::uint32_t list_capacity_, knit_capacity_;
  // What lists built for an anchor were built for: its positions (the fluid's sorts), the knit
  // grid's sort, the counts. begin_step keeps them while all still hold (empty: nothing kept).
  struct Built {
    std::uint64_t fluid_sorts = 0, knit_sorts = 0;
    std::size_t fluid = 0, knit = 0;
    bool operator==(const Built&) const = default;
  };
  std::optional<Built> built_;
  std::uint64_t list_builds_ = 0;
  std::uint32_t last_near_ = 0;
  T flag_slack_ = 0;
  // N ranks (distribute): as KnitSelfContact's.
  std::size_t active(const KnitSet<T>& knit) const { return std::min(active_, knit.size()); }
  bool ties_by_id_ = false;
  std::size_t active_ = std::size_t(-1);
  T cell_;
};

} // namespace kf
