#pragma once
// The fluid and boundary particles of one rank of a job split in space (DESIGN §6; the plan in
// docs/ARCHITECTURE.md, "The step on N ranks"). Between steps a rank holds only the fluid it
// owns; at each sort (rebuild) the fluid that left its blocks migrates to their owners and the
// ghosts within the support of its region are received and appended, to be dropped again after
// the forces pass. The boundary: owned particles plus ghosts received once, or at every step
// where solids move (boundary_moved). Ghost values that a pass computes from neighbours a ghost
// lacks (summation density; the forces kept ghosts move by) are refreshed from their owners; the
// ghost walls compute their own pressures, the fluid beside walls coming twice as far
// (walls_pass). On a device backend the particles stay in device memory: the
// rows that move are packed there (DeviceRows) and staged through the host for MPI; the owners
// and the ghosts are chosen there too (RankSelector), only their indices coming to the host.
#include "comm/HaloExchange.hpp"
#include "comm/MpiContext.hpp"
#include "comm/Transport.hpp"
#include "domain/Decomposition.hpp"
#include "domain/DeviceRows.hpp"
#include "domain/PairCostFit.hpp"
#include "domain/RankLayout.hpp"
#include "domain/RankSelector.hpp"
#include "domain/Scene.hpp"
#include "kernels/exec/Stopwatch.hpp"
#include "kernels/exec/Streams.hpp"
#include "kernels/particles/FluidSet.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <vector>

namespace kf {

template <typename T>
class RankExchange {
public:
  /// `split`: the knit's width (the blocks' scale where there is no fluid), the coupling's
  /// reach (the fluid's ghosts reach that far too) and the "verlet" lists' skin (the fluid's
  /// ghosts then reach the skin farther and are kept between the sorts, keeps_ghosts(), their
  /// state refreshed after each forces pass); the widths follow from them (halo_widths).
  RankExchange(const comm::MpiContext& mpi, const Scene& scene, exec::Backend backend,
               const SplitInputs& split = {});

  int rank() const { return mpi_.rank(); }
  /// Whether the fluid's ghosts stay from one sort to the next ("verlet" lists).
  bool keeps_ghosts() const { return keeps_ghosts_; }
  int ranks() const { return mpi_.size(); }
  exec::Backend backend() const { return backend_; }
  /// How the exchanges read and write the particles' buffers (the backend's memory).
  comm::RowCopier& rows() { return *rows_; }
  const Decomposition& decomposition() const { return *decomposition_; }
  /// Each phase's ghost width, the blocks' edge (RankLayout).
  const HaloWidths& widths() const { return widths_; }
  const comm::MpiContext& mpi() const { return mpi_; }

  /// At the start, every rank holding the whole scene: partitions by its particles' costs, keeps
  /// the fluid this rank owns, and the boundary it owns plus, received from their owners, the
  /// boundary ghosts (sort the boundary after, then boundary_sorted()).
  /// knit: the knit points' positions (the whole knit, as every rank built it), counted in the
  /// blocks' costs; KnitHalo keeps this rank's share.
  /// step: the run's (a restart's), from which the imbalance checks count.
  void distribute(FluidSet<T>* fluid, BoundarySet<T>* boundary, std::span<const Vec3<T>> knit = {},
                  std::uint64_t step = 0);
  /// At the start, each rank holding only the fluid and the boundary it owns by `d` (the first
  /// partition every rank computed alike from the whole scene, first_partition): takes `d` and
  /// receives the boundary ghosts from their owners, as distribute() ends (sort the boundary
  /// after, then boundary_sorted()). No rank then ever holds the whole scene on its device.
  void adopt(Decomposition d, FluidSet<T>* fluid, BoundarySet<T>* boundary, std::uint64_t step = 0);
  void boundary_sorted(const exec::DeviceBuffer<std::uint32_t>& perm, std::size_t n);
  /// After moving solids moved their boundary particles (every rank its owned and ghost ones,
  /// alike): the owned go to their blocks' owners and the ghosts are chosen anew (collective;
  /// sort the boundary after, then boundary_sorted()).
  void boundary_moved(BoundarySet<T>& boundary);

  struct Removed {
    std::uint64_t particles = 0;
    double mass = 0;
  };
  /// Before the fluid's sort: the owned fluid outside [lo, hi] on an open side is removed
  /// (counted), the rest migrates to its owners, and the ghosts are received. Nothing closes up:
  /// the rows that went (leavers, the kept ghosts still held from the last sort) keep their
  /// places, the arrivals and then the new ghosts follow them, and rebuilt_rows() flags the rows
  /// to keep; the sort drops the others (NeighbourGrid::build_keeping, KeepBox::everywhere): one
  /// pass over the columns fewer than a compaction before the sort.
  /// acceleration: the migrants take their a along (FluidSet::Carry's: a sort at a step's start,
  /// after an absorption or an emission, comes before the half kick that reads it).
  /// beside_walls (geometry and cells; its width is this class's): the cells with walls around
  /// (NeighbourGrid::occupied_around of the boundary's grid), required where the scene has walls.
  /// The fluid in them goes to the ranks within twice the walls' ghost width, so that walls_pass
  /// computes the ghost walls' pressures here.
  Removed rebuild(FluidSet<T>& fluid, const Vec3<T>& lo, const Vec3<T>& hi,
                  const std::array<bool, 6>& walls, bool acceleration,
                  const WiderCells<T>& beside_walls = {});
  /// After rebuild(): 1 for each of the fluid's rows the sort keeps, 0 for those it drops (on the
  /// backend; valid until the sort).
  const std::uint32_t* rebuilt_rows() const { return alive_.data(); }
  /// After the fluid's sort of the rebuild's `rows` rows: perm[k] is where the particle now at k
  /// was, for the first `kept` (the dropped ones sorted after them and gone).
  void fluid_sorted(const exec::DeviceBuffer<std::uint32_t>& perm, std::size_t rows,
                    std::size_t kept);
  /// A pass over the particles `rows` names (the caller's kernels, its own timing).
  using Pass = std::function<void(const exec::Rows&)>;
  /// The density pass, and the ghosts' rho, P and the packed copies it writes (vp, vol) from
  /// their owners. With [parallel] overlap the pass runs over the owned rows the peers receive,
  /// then over the other owned rows while the exchange is in flight (a ghost's own values would
  /// be overwritten: it is not computed); without, over every row, then the exchange.
  void refresh_density(FluidSet<T>& fluid, const Pass& pass);
  /// The walls' pressure pass over all n boundary particles, owned and ghost: the fluid beside
  /// a ghost wall came with the fluid's ghosts (rebuild's beside_walls), its pressure needs no
  /// exchange. Not collective.
  void walls_pass(std::size_t n, const Pass& pass);
  /// After the forces pass: only the owned fluid stays.
  void drop_ghosts(const exec::Exec& ex, FluidSet<T>& fluid);
  /// With the knit coupled, after the kick: the ghosts' velocities, accelerations and densities
  /// from their owners (the coupling reads the fluid around each knit point before the next
  /// drift).
  void refresh_motion(FluidSet<T>& fluid);
  /// With "verlet" lists: the forces pass, as refresh_density runs its own, and what it wrote (a;
  /// under continuity also rho, drho and drho_prev) from the owners, so that the kick and the
  /// drift then move each ghost exactly as its owner moves it (its v and x follow: the same
  /// arithmetic on the same values). defer (with [parallel] overlap): the exchange is left in
  /// flight, finished by finish_forces() once the owned rows' kick is queued (forces_pending()
  /// until then; any other exchange or rebuild finishes it first).
  void refresh_forces(FluidSet<T>& fluid, bool continuity, const Pass& pass, bool defer = false);
  bool forces_pending() const { return fluid_halo_ && fluid_halo_->pending(); }
  void finish_forces();
  /// The rows the fluid's ghosts hold (on the backend; valid until the fluid's next sort).
  exec::Rows ghost_rows();
  /// The forces pass where the ghosts go after it (drop_ghosts): over the owned rows only (with
  /// [parallel] overlap the border's, then the rest; else in one pass that skips the ghosts).
  void owned_pass(std::size_t n, const Pass& pass);
  /// The first n fluid rows with those this rank owns flagged: a pass over them skips the
  /// ghosts (exec::Rows::only).
  exec::Rows owned_rows(std::size_t n) const;
  /// Kept ghosts' positions and velocities from their owners (after a drift that moved a ghost
  /// otherwise than its owner).
  void refresh_positions(FluidSet<T>& fluid);
  /// The ghosts' rows of further columns (the set's order) from their owners.
  void refresh(std::span<const comm::Column> columns);
  /// Keeps the owned fluid flagged 1 in keep (the set's order; ghosts flagged 0): the ghosts go
  /// with the rest (sort the fluid after, collectively).
  void remove(const exec::Exec& ex, FluidSet<T>& fluid,
              const exec::DeviceBuffer<std::uint32_t>& keep);
  /// After particles were appended to the fluid holding only the owned (drop_ghosts): they are
  /// this rank's until the next sort sends them to their owners.
  void appended(const FluidSet<T>& fluid);
  /// 1 for the fluid this rank owns, 0 for its ghosts, in the set's order (a copy to the host:
  /// for the output's cadence).
  std::vector<std::uint32_t> fluid_owned() const { return keep_.to_host(); }
  std::size_t fluid_owned_count() const { return fluid_owned_; }
  std::size_t boundary_owned_count() const { return boundary_own_count_; }
  /// fluid_owned() on the backend (valid until the fluid's next sort or resize).
  const std::uint32_t* owned_flags() const { return keep_.data(); }

  /// Seconds of local work (passes that wait for no other rank) on one phase's particles, for
  /// the imbalance and the phases' measured costs.
  void add_compute(double seconds, Phase phase = Phase::Fluid) {
    compute_seconds_ += seconds;
    phase_seconds_[static_cast<int>(phase)] += seconds;
  }
  /// The same, timed on the backend: the work queued between start() and stop() (read at the
  /// imbalance check, without stalling the host behind the device before).
  exec::Stopwatch& clock(Phase phase) { return *clocks_[static_cast<int>(phase)]; }
  struct Balance {
    double imbalance = 0; // slowest rank's compute over the mean since the last check (0: none)
    bool repartitioned = false;
  };
  /// Whether balance() at this step checks the imbalance (and may re-partition: the fluid must
  /// then hold only what this rank owns).
  bool balance_due(std::uint64_t step) const {
    return window_of(step) > window_of(last_check_step_);
  }
  /// At the first sort [parallel] check_every steps or more after the last check (call before a
  /// rebuild, the fluid holding only what this rank owns): when the measured imbalance passes
  /// [parallel] imbalance (and, with [parallel] payback, the time it loses until the next
  /// re-partition would be due reaches what the last one cost), the blocks are partitioned anew by
  /// the particles' current counts, each phase's weighed by its measured cost a particle (the job's
  /// seconds on the phase over its particles since the last check), and the fluid and the boundary
  /// migrate to their new owners (sort the boundary after, then boundary_sorted()); the knit
  /// follows at KnitHalo's next choice. knit_x: the knit's positions, the first knit_owned this
  /// rank's (read only at a re-partition). knit_pairs: the coupling's pairs listed for each knit
  /// point (its first knit_owned, in the set's order; null without the coupling), sampled at
  /// every check with the knit's seconds (PairCostFit) and weighed in the blocks' knit counts.
  Balance balance(std::uint64_t step, FluidSet<T>* fluid, BoundarySet<T>* boundary,
                  const exec::DeviceBuffer<Vec3<T>>* knit_x = nullptr, std::size_t knit_owned = 0,
                  const exec::DeviceBuffer<std::uint32_t>* knit_pairs = nullptr);
  /// What the knit's exchange shares: the transport, the ranks next to this one's blocks (a
  /// particle moves less than a block a step), and the split's own time.
  comm::Transport& transport() { return *transport_; }
  std::string_view transport_name() const { return transport_->name(); }
  /// Where the transport's buffers live (device: it all-reduces the step size's bounds there).
  comm::MemorySpace transport_space() const { return transport_->memory_space(); }
  /// Each position's owning rank (-1 for other ranks' with others_dropped: a migration's
  /// destinations that keep only this rank's particles).
  std::vector<int> owners(std::span<const Vec3<T>> x, bool others_dropped = false) const;
  /// Of the first n positions (this rank's), those each neighbour needs as ghosts: within `width`
  /// of its blocks (select_ghosts' lists), chosen on the positions' backend.
  /// Held by the copier rows() (on a device: the lists stay there).
  typename RankSelector<T>::GhostRows ghost_rows(const exec::DeviceBuffer<Vec3<T>>& x,
                                                 std::size_t n, double width) {
    return select_.ghost_rows(x, n, width, rows());
  }
  /// Every rank but this one (the peers of a migration after a re-partition).
  std::vector<int> other_ranks() const;
  const std::vector<int>& migration_peers() const { return migration_peers_; }
  /// Adds the seconds of its scope to exchange_seconds().
  struct Timed {
    double& sum;
    std::chrono::steady_clock::time_point t0 = std::chrono::steady_clock::now();
    ~Timed() {
      sum += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    }
  };
  /// The split's own work outside this class (KnitHalo) counts in exchange_seconds() too.
  Timed time_exchange() { return Timed{exchange_seconds_}; }
  /// The step size's all-reduce (the caller's): counted in exchange_seconds() and its part.
  void add_reduction(double seconds) {
    exchange_seconds_ += seconds;
    parts_.reduction += seconds;
  }
  std::uint64_t repartitions() const { return repartitions_; }
  /// Checks past the threshold where a re-partition would not have paid ([parallel] payback).
  std::uint64_t declined_repartitions() const { return declined_; }
  /// Checks past the threshold where the particles' counts were balanced already (within twice
  /// METIS's allowance: Decomposition::repartition_promises; [parallel] payback).
  std::uint64_t balanced_declines() const { return declined_balanced_; }
  /// The current partition's imbalance by the counts at the last check that counted (0: none).
  double last_counted_imbalance() const { return last_counted_imbalance_; }
  /// The largest counted imbalance among those declines (0: none).
  double declined_counted_imbalance() const { return declined_counted_; }
  /// The job's slowest rank's seconds in the last re-partition (0: none yet).
  double last_repartition_seconds() const { return last_repartition_seconds_; }
  /// What METIS took of it (the slowest rank's seconds).
  double last_partition_seconds() const { return last_partition_seconds_; }
  /// The split's seconds by part (within exchange_seconds(); the knit's ghosts are the rest).
  struct Parts {
    double migration = 0; // fluid leaving, migrating, its ghosts chosen and received
    double refresh = 0;   // the fluid's and the boundary's ghost refreshes, the ghosts dropped
    double rebalance = 0; // the imbalance checks and re-partitions with their migrations
    double reduction = 0; // the step size's all-reduce: mostly the wait for the slowest rank
    double packing = 0;   // inside all of them (the knit's too): packing and unpacking rows
  };
  Parts parts() const {
    Parts p = parts_;
    p.packing = rows_->seconds();
    return p;
  }
  /// Seconds spent in the split's own work (migration, ghosts, refreshes, re-partitions).
  double exchange_seconds() const { return exchange_seconds_; }
  double last_imbalance() const { return last_imbalance_; }
  /// At the last check: each phase's slowest rank, summed, over the mean rank's compute. The
  /// phases meet at refreshes, so a rank slower in one phase and faster in another waits twice
  /// while its total is balanced: this is at least last_imbalance() and bounds what the waits
  /// between phases lose.
  double last_phase_imbalance() const { return last_phase_imbalance_; }
  /// At the last check: each phase's slowest rank over that phase's mean (0: a phase not timed
  /// apart, as the boundary's passes, timed with the fluid's). last_phase_imbalance() is their
  /// mean weighted by each phase's share of the compute, so it lies between the least and the
  /// most of them.
  const std::array<double, kPhases>& last_phase_spread() const { return last_phase_spread_; }
  /// The phases' costs the last partition weighed by (measured from the second on).
  const PhaseCosts& phase_costs() const { return costs_; }
  /// A coupling pair's cost in knit points, as measured so far (0: not yet told apart).
  double pair_weight() const { return pair_fit_.weight(); }

  /// Boundary particles this rank owns (1) and holds as ghosts (0), in the set's order.
  const std::vector<std::uint8_t>& boundary_owned() const { return boundary_owned_; }
  /// The refreshes inside the fluid's passes (density, walls, forces): each pass and the exchange
  /// after it (with overlap, the wait the interior's pass left) timed on the device, without
  /// synchronising (`run --profile-device`); read by collect_refresh_times().
  static constexpr int kRefreshes = 3;
  struct RefreshTimes {
    std::array<double, kRefreshes> pass{}, exchange{};
  };
  void time_refreshes_on_device();
  /// Seconds so far (waits for the last interval's work).
  const RefreshTimes& collect_refresh_times();
  /// Ghost count and bytes moved by the last rebuild's and refreshes' exchanges (progress).
  std::size_t fluid_ghosts() const { return fluid_halo_ ? fluid_halo_->received() : 0; }

private:
  /// The boundary ghosts of this rank's region from their owners, appended after the `owned`
  /// particles (which come first in the set).
  void receive_boundary_ghosts(BoundarySet<T>& boundary, std::size_t owned);
  /// The owned boundary to its blocks' owners (chosen on the backend), the ghosts dropped and
  /// received anew. The peers: every other rank where `to_everyone` (the same on every rank),
  /// else the neighbours unless a leaver somewhere goes farther (collective).
  void migrate_boundary(BoundarySet<T>& boundary, bool to_everyone);
  /// boundary_owned_ as flags on the backend (1 owned, 0 a ghost), valid while boundary_owned_
  /// stands (uploaded once after each change).
  const std::uint32_t* boundary_owned_flags();
  exec::DeviceBuffer<std::uint32_t> boundary_owned_flags_{exec::Backend::Cpu, 0,
                                                          "ranks.boundary_owned"};
  /// After a sort of `rows` rows that kept the first `kept` of perm, the halo's lists (of kept
  /// rows) follow their particles; its ghosts were received at row `first_ghost`.
  void remap(comm::HaloExchange& halo, const exec::DeviceBuffer<std::uint32_t>& perm,
             std::size_t rows, std::size_t kept, std::size_t first_ghost);
  /// The fluid holds only what this rank owns: every flag 1.
  void all_owned();
  /// The blocks' owners from now on, and the ranks a particle may migrate to.
  void take_partition(Decomposition d);
  /// Finishes a deferred forces' refresh (before anything else uses the halo).
  void settle_forces();
  /// The fluid's rows moved or changed hands: the split lists and the ghosts' list are stale.
  void fluid_rows_changed();
  exec::DeviceBuffer<std::uint32_t> ghost_list_{exec::Backend::Cpu, 0, "ranks.ghost_rows"};
  bool ghost_list_current_ = false;
  /// A halo's owned rows split for a pass around its exchange: those it sends (the border), and
  /// the others, on the backend. Built at the first pass after the halo or the order changed.
  struct SplitRows {
    exec::DeviceBuffer<std::uint32_t> border, interior, flags, scratch, sent;
    bool current = false;
  };
  /// `out` current: owned(out.flags) writes 1 for an owned row and 0 for a ghost; those less the
  /// halo's sent rows become out.interior, the sent rows (each once, ascending) out.border.
  SplitRows& split(const comm::HaloExchange& halo, SplitRows& out,
                   const std::function<void(exec::DeviceBuffer<std::uint32_t>&)>& owned);
  /// overlapped over the fluid's halo (or the pass over all n rows where there is none).
  void fluid_pass(std::span<const comm::Column> cols, std::size_t n, const Pass& pass, bool overlap,
                  int refresh, bool finish = true);
  // The refreshes timed on the device (time_refreshes_on_device): a pass and an exchange each.
  std::array<std::unique_ptr<exec::Stopwatch>, 2 * kRefreshes> refresh_clocks_;
  std::size_t refresh_uses_ = 0;
  RefreshTimes refresh_times_;
  /// Runs `what` inside clock k's interval (when the refreshes are timed).
  template <typename F>
  void on_clock(int k, F&& what);
  /// pass over the owned rows and the halo's exchange of cols, overlapped where the scene asks.
  /// (rows null: over all n rows, then the exchange.) finish false: the exchange is left in
  /// flight.
  void overlapped(comm::HaloExchange& halo, const SplitRows* rows,
                  std::span<const comm::Column> cols, std::size_t first_ghost, std::size_t n,
                  const Pass& pass, int refresh, bool finish = true);
  /// The fluid's and the boundary's split, current.
  SplitRows& fluid_rows();
  SplitRows fluid_split_;

  const comm::MpiContext& mpi_;
  exec::Backend backend_;
  std::unique_ptr<comm::RowCopier> rows_;
  Parts parts_; // all but packing (the copier's)
  std::array<double, kPhases> last_phase_spread_{};
  double compute_seconds_ = 0, last_imbalance_ = 0, last_phase_imbalance_ = 0,
         exchange_seconds_ = 0;
  std::uint64_t repartitions_ = 0, declined_ = 0, declined_balanced_ = 0;
  double last_counted_imbalance_ = 0, declined_counted_ = 0;
  double last_repartition_seconds_ = 0, last_partition_seconds_ = 0;
  std::uint64_t checks_held_ = 0; // imbalance checks since the last re-partition (this one too)
  bool keeps_ghosts_ = false;
  bool overlap_ = false;       // [parallel] overlap, where it applies
  bool overlap_short_ = false; // the same for the forces' refresh (host messages)
  // Where a split pass's interior runs beside its border and the exchange (a device; null: after
  // them, on the CPU or with KF_SIDE_STREAM=0).
  std::unique_ptr<exec::SideStream> side_;
  std::uint64_t last_check_step_ = 0; // the step of the last imbalance check (or the start)
  PairCostFit pair_fit_;
  std::uint64_t window_of(std::uint64_t step) const {
    return step / static_cast<std::uint64_t>(scene_.parallel.check_every);
  }
  PhaseCosts costs() const { return costs_; }
  PhaseCosts costs_;
  std::array<double, kPhases> phase_seconds_{};
  std::array<std::unique_ptr<exec::Stopwatch>, kPhases> clocks_;
  Scene scene_;
  std::unique_ptr<comm::Transport> transport_;
  std::optional<Decomposition> decomposition_;
  RankSelector<T> select_;
  HaloWidths widths_;
  std::vector<int> migration_peers_;
  std::optional<comm::HaloExchange> fluid_halo_, boundary_halo_;
  std::size_t fluid_owned_ = 0, boundary_own_count_ = 0;
  std::vector<std::uint8_t> boundary_owned_;
  bool boundary_flags_uploaded_ = false; // boundary_owned_flags_ holds boundary_owned_
  // The fluid's 1 owned, 0 ghost, in the set's order (as keep_flagged takes them), on the
  // backend; a sort's inverse permutation.
  exec::DeviceBuffer<std::uint32_t> keep_, inverse_;
  // rebuild()'s rows to keep (rebuilt_rows()).
  exec::DeviceBuffer<std::uint32_t> alive_;
};

} // namespace kf
