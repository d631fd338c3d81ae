#pragma once
// SimulationT<T>: the pipeline in precision T on one backend, behind Simulation. Its members are
// defined by phase: SimulationT.cpp (set-up and the pipeline's stages), SimulationFluid.cpp (the
// fluid and boundary passes with the halos each reads), SimulationStep.cpp (the step size and the
// step), SimulationSnapshot.cpp (frames and restart), SimulationDiagnostics.cpp,
// SimulationWatch.cpp (the watchdog's reading).
#include "core/Error.hpp"
#include "domain/AbsorptionRanks.hpp"
#include "domain/FrameFields.hpp"
#include "domain/KnitBuilder.hpp"
#include "domain/KnitHalo.hpp"
#include "domain/KnitSystem.hpp"
#include "domain/LocalWork.hpp"
#include "domain/MeshObstacle.hpp"
#include "domain/PartitionPlan.hpp"
#include "domain/RankExchange.hpp"
#include "domain/RigidShapes.hpp"
#include "domain/Samplers.hpp"
#include "domain/SceneParams.hpp"
#include "domain/Simulation.hpp"
#include "domain/StageParts.hpp"
#include "kernels/boundary/Boundary.hpp"
#include "kernels/coupling/Absorption.hpp"
#include "kernels/coupling/KnitFluidCoupling.hpp"
#include "kernels/coupling/SheetGuard.hpp"
#include "kernels/exec/PendingRead.hpp"
#include "kernels/grid/NeighbourGrid.hpp"
#include "kernels/grid/NeighbourList.hpp"
#include "kernels/integrate/StepSize.hpp"
#include "kernels/integrate/Verlet.hpp"
#include "kernels/integrate/Watch.hpp"
#include "kernels/particles/FluidSet.hpp"
#include "kernels/particles/Outflow.hpp"
#include "kernels/sph/Sph.hpp"
#include "kernels/sph/SphLists.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <optional>
#include <sstream>
#include <type_traits>
#include <vector>

namespace kf {

template <typename T>
class SimulationT final : public Simulation {
public:
  /// How far the constructor goes: the stage list only (`knitflow plan`); the particles, knit
  /// and coupling as a run starts them, not split and no forces evaluated (the plan's partition,
  /// split_plan()); a run.
  enum class Build { Stages, Particles, Run };
  SimulationT(const Scene& scene, exec::Backend backend, Build build = Build::Run,
              const comm::MpiContext* mpi = nullptr);
  /// The split over `ranks` the run would start with (RankLayout's rules, as RankExchange takes
  /// them), with what each rank would own and receive (PartitionPlan). Built with
  /// Build::Particles on one rank.
  PartitionReport split_plan(int ranks);

  double step(double t_limit) override;
  double time() const override { return time_; }
  std::uint64_t steps() const override { return steps_; }
  double stable_dt() override;
  io::Frame frame() const override;
  void restore(const io::Frame& frame) override;
  Diagnostics diagnostics() const override;
  WatchReading watch() override;
  std::string describe_worst(WatchMeasure measure) const override;
  const Pipeline& pipeline() const override { return pipeline_; }
  const Scene& scene() const override { return scene_; }
  exec::Backend backend() const override { return ex_.backend; }
  std::size_t memory_bytes() const override;
  RankReport rank_report() const override {
    if (!ranks_)
      return {};
    const auto p = ranks_->parts();
    return {ranks_->ranks(),
            ranks_->last_imbalance(),
            ranks_->exchange_seconds(),
            p.migration,
            p.refresh,
            p.rebalance,
            p.packing,
            p.reduction,
            std::string(ranks_->transport_name()),
            refresh_times_.pass,
            refresh_times_.exchange,
            fluid_grid_      ? fluid_grid_->geometry().cells()
            : boundary_grid_ ? boundary_grid_->geometry().cells()
                             : 0u,
            fluid_grid_ || boundary_grid_ ? whole_grid_.cells() : 0u,
            {ranks_->fluid_owned_count(), ranks_->boundary_owned_count(),
             knit_halo_ ? knit_halo_->owned() : 0u}};
  }
  void set_profiling(bool on) override {
    profiling_ = on;
    stage_parts::enable(on, ex_.backend);
  }
  void profile_on_device() override {
    pipeline_.time_on_device(ex_.backend);
    if (ranks_)
      ranks_->time_refreshes_on_device();
  }
  void collect_device_profile() override {
    pipeline_.collect_device();
    if (ranks_)
      refresh_times_ = ranks_->collect_refresh_times();
  }

private:
  typename RankExchange<T>::RefreshTimes refresh_times_; // collect_device_profile()
  void build_pipeline();
  /// The particles, the knit and the coupling as the scene starts them. split_over (N ranks):
  /// the fluid and the boundary kept by the first partition (first_split_, split_), this
  /// rank's share only; their grids are made by fit_grids_to_region then.
  void init_particles(const comm::MpiContext* split_over = nullptr);
  std::optional<Decomposition> first_split_; // until RankExchange::adopt takes it
  SplitInputs split_;
  double whole_fluid_mass_ = 0; // every rank's, summed as one rank sums its particles'
  void init_coupling();
  void init_absorption(const CouplingParams<T>& cp);
  void update_shapes(double t);
  /// remove_outflow: the fluid outside the domain is removed in the same sort (counted).
  /// acceleration false: a is not carried (a forces pass follows before anything reads it).
  void sort_fluid(bool remove_outflow = false, typename FluidSet<T>::Carry carry = {});
  void sort_boundary();
  /// On N ranks, after each partition: the fluid's and the boundary's grids cover this rank's
  /// blocks and the ghosts' reach, not the whole domain (NeighbourGrid::within).
  void fit_grids_to_region();
  /// What the split over ranks takes from the knit and the coupling (halo_widths).
  SplitInputs split_inputs();
  /// Restart: the fluid's grid (and lists) as the run that wrote fr holds them (see restore).
  void restore_fluid_grid(const io::Frame& fr);
  void compute_forces();
  /// The sph.density and sph.forces stages for a step of dt (0: at t = 0).
  void fluid_density(T dt);
  bool density_done_ = false; // this step's sph.density ran early (while the lists were read)
  void fluid_forces(T dt);
  bool continuity() const { return scene_.solver.density == DensityModel::Continuity; }
  bool shifting() const {
    return fluid_on_ && scene_.solver.shifting == Scene::Solver::Shifting::Fickian;
  }
  /// Particle shifting over the owned fluid after the forces pass, at its positions (sph_shift),
  /// for a step of dt (0: none).
  void shift_fluid(T dt);
  BoundaryNeighbours<T> boundary_neighbours();
  void extrapolate_boundary_pressure();
  /// Velocity factor of one half kick of a step h: exp(-zeta h / 2) while settling, else 1.
  T damping_keep(double h) const {
    const auto& s = scene_.solver;
    return (s.damping > 0 && time_ < s.damping_until)
               ? static_cast<T>(std::exp(-0.5 * s.damping * h))
               : T(1);
  }
  /// Throws InstabilityError naming the step, the time, why, and the worst particle by the
  /// measure. Collective on N ranks: every instability is found from the job's bounds.
  [[noreturn]] void report_instability(const std::string& why,
                                       WatchMeasure worst = WatchMeasure::FluidSpeed);
  /// This rank's particle with the largest measure (non-finite first): its description ("" if
  /// none) and *value (-1 if none). Not collective (report_instability's, describe_worst's).
  std::string local_worst(WatchMeasure measure, double* value) const;
  /// The knit's stable dt (from bounds already read, or read now), its instability reported
  /// with its worst point.
  double knit_stable_dt(const MotionBounds<T>* bounds);

  Scene scene_;
  exec::Exec ex_;
  bool fluid_on_ = false, boundary_on_ = false, knit_on_ = false, moving_ = false;
  bool coupling_on_ = false;
  double coupling_fluid_limit_ = 1e30; // fluid step bound from the knit-fluid contact
  FluidSide<T> fluid_side() {
    const auto cells = fluid_grid_->view();
    const bool near = fluid_near_.size() == cells.geo.cells(); // sort_fluid's, with the grid's
    return {fluid_->view(), cells, near ? fluid_near_.data() : nullptr};
  }
  SphParams<T> sph_;
  exec::DeviceBuffer<Vec3<T>> shift_{exec::Backend::Cpu, 0, "sph.shift"}; // shift_fluid's
  double h_ = 0, margin_ = 0;
  double time_ = 0, dt_ = 0;
  std::uint64_t steps_ = 0;
  // Particles put back by the guard, whole run: a counter in device memory, read only for
  // snapshots and diagnostics so the step never waits for it.
  exec::DeviceBuffer<std::uint64_t> guard_count_{exec::Backend::Cpu, 0, "boundary.guard_count"};
  std::uint64_t guard_corrections() const { return guard_count_.host_value(0); }
  std::uint64_t outflow_particles_ = 0, fluid_sorts_ = 0;
  double outflow_mass_ = 0; // removed before the restart this run started from (its snapshot's)
  // The mass removed by sorts since (sort_removing_outside), summed on the device: read with the
  // diagnostics, not at every sort.
  exec::DeviceBuffer<double> sorted_outflow_mass_{exec::Backend::Cpu, 0, "fluid.outflow"};
  double outflow_mass() const { return outflow_mass_ + sorted_outflow_mass_.host_value(0); }
  bool profiling_ = false;

  std::optional<KnitSystem<T>> knit_;
  std::optional<KnitFluidCoupling<T>> coupling_;
  std::optional<ConservingAbsorption<T>> absorption_; // capillary.model = "conserving"
  // The tunnelling guard (coupling.sheet_guard) and its count of particles put back, whole run
  // (device memory, read with the diagnostics).
  bool sheet_guard_on_ = false;
  double sheet_guard_width_ = 0; // the knit ghosts' width the guard needs on N ranks
  std::optional<SheetGuard<T>> sheet_guard_;
  exec::DeviceBuffer<std::uint64_t> sheet_count_{exec::Backend::Cpu, 0, "sheet_guard.count"};
  // The knit's positions at the step's start (its faces' motion over the step).
  exec::DeviceBuffer<Vec3<T>> sheet_x0_{exec::Backend::Cpu, 0, "sheet_guard.knit_x0"};
  std::uint64_t sheet_corrections() const {
    return sheet_count_.size() ? sheet_count_.host_value(0) : 0;
  }
  void init_sheet_guard();
  /// After the fluid's drift: fluid whose step crossed the knit's sheet goes back to its side
  /// and meets the face inelastically, the knit taking the reaction (on N ranks the knit's
  /// ghosts' positions are current, refreshed after every substep's drift; the reaction's sums
  /// go from ghosts to owners and back).
  void guard_sheet() {
    typename SheetGuard<T>::GhostSums sums;
    if (knit_halo_) {
      // The knit step's closing half kick left its ghosts' velocities half a kick behind (they
      // were refreshed after the drift); the reaction reads the corners' velocities.
      const comm::Column v[] = {column(knit_->set().v)};
      knit_halo_->refresh(v);
      sums = [this](exec::DeviceBuffer<std::uint64_t>& s, bool back) {
        knit_halo_->add_to_owners(s, kSheetSumWidth, back);
      };
    }
    sheet_guard_->apply(ex_, fluid_->view(), static_cast<T>(dt_), knit_->set(), sheet_x0_,
                        *coupling_, knit_halo_ ? knit_halo_->local_of_id().data() : nullptr,
                        kept_ghosts_flags(), sheet_count_.data(), sums);
  }
  std::uint64_t next_fluid_id_ = 0;
  PoreMass<T> pores() const { return absorption_ ? absorption_->pores() : PoreMass<T>{}; }
  /// The coupling's step opens (the saturation, then the knit grid and the lists for the knit's
  /// motion over the step): the step's size is waited for between the two, its read queued
  /// before the saturation's passes (settle_dt), except on N ranks where the ghosts need it first.
  void begin_coupling() {
    if (knit_halo_) { // the knit's ghosts current, and their saturation their owners'
      settle_dt();
      stage_parts::Scope part("coupling.begin: knit ghosts (refreshed, or chosen anew)");
      knit_halo_->begin(knit_->expected_motion(dt_));
    }
    coupling_->update_saturation(ex_, knit_->set(), fluid_side(), pores(), share_saturation());
    settle_dt();
    coupling_->begin_lists(ex_, knit_->set(), fluid_side(),
                           static_cast<T>(knit_->expected_motion(dt_)), coupling_anchor());
  }
  /// With "verlet" lists: the fluid's lists' positions, so that the coupling's lists last as
  /// long as they may (FluidAnchor). On N ranks the ghosts are kept from one sort to the next
  /// with them (RankExchange::keeps_ghosts): the rows stay in place, each ghost listed where its
  /// owner was (both sorted at the same step), and the bound is the job's.
  FluidAnchor<T> coupling_anchor() const {
    if (!fluid_list_ || (ranks_ && !ranks_->keeps_ghosts()))
      return {};
    return {fluid_list_->listed_x(fluid_->size()), fluid_sorts_, fluid_list_->displacement_bound()};
  }
  /// The coupling's pairs listed for each knit point, in the knit set's order, for the blocks'
  /// weights (RankExchange::balance); null without the coupling or before its lists were built
  /// for the set as it is (a knit ghost choice builds them again at the next step's start).
  const exec::DeviceBuffer<std::uint32_t>* coupling_pairs() {
    if (!coupling_on_ || !coupling_ || coupling_->knit_rows().rows() != knit_->set().size())
      return nullptr;
    return &coupling_->knit_rows().counts();
  }
  /// On N ranks: the knit ghosts take their owners' saturation, capillary pressure and wet mass.
  std::function<void()> share_saturation() {
    if (!knit_halo_)
      return {};
    return [this] {
      stage_parts::Scope part("coupling.begin: knit ghosts' saturation from their owners");
      const auto v = coupling_->knit_values();
      const comm::Column cols[] = {
          {v[0]->data(), sizeof(T)}, {v[1]->data(), sizeof(T)}, {v[2]->data(), sizeof(T)}};
      knit_halo_->refresh(cols);
    };
  }
  /// After a restart: the knit's saturation for the state restored, for snapshots and
  /// diagnostics before the next step (on N ranks the knit's points were shared out anew).
  /// The ghosts are chosen first: diagnostics keep the set's points as they are (current()).
  void update_saturation() {
    with_knit_ghosts([this] {
      coupling_->update_saturation(ex_, knit_->set(), fluid_side(), pores(), share_saturation());
    });
  }
  /// Before the fluid's drift on N ranks with the knit coupled: the ghosts the coupling read go
  /// (with "verlet" lists they stay until the next sort: after_drift()).
  void drop_coupled_ghosts() {
    if (ranks_ && coupling_on_ && !ranks_->keeps_ghosts())
      ranks_->drop_ghosts(ex_, *fluid_);
  }
  /// On N ranks with ghosts kept over steps, 1 for the owned fluid and 0 for the ghosts (on the
  /// backend); else null.
  const std::uint32_t* kept_ghosts_flags() const {
    return ranks_ && ranks_->keeps_ghosts() ? ranks_->owned_flags() : nullptr;
  }
  /// After the fluid's drift on N ranks with the knit coupled and the ghosts kept: the coupling's
  /// impulse on a ghost is not its owner's, so the ghosts take their owners' positions and
  /// velocities.
  void after_drift() {
    if (ranks_ && coupling_on_ && ranks_->keeps_ghosts())
      ranks_->refresh_positions(*fluid_);
  }
  /// The fluid rows this rank writes and counts: all, or on N ranks with ghosts kept between
  /// steps (the knit coupled, or "verlet" lists) the owned ones.
  std::vector<std::uint8_t> fluid_owned_rows() const {
    std::vector<std::uint8_t> m(fluid_->size(), 1);
    if (ranks_ && fluid_->size() != ranks_->fluid_owned_count()) {
      const auto& f = ranks_->fluid_owned();
      if (f.size() != m.size())
        throw Error("internal: " + std::to_string(f.size()) + " ownership flags for " +
                    std::to_string(m.size()) + " fluid particles");
      for (std::size_t i = 0; i < m.size(); ++i)
        m[i] = f[i] ? 1 : 0;
    }
    return m;
  }
  std::optional<FluidSet<T>> fluid_;
  std::optional<BoundarySet<T>> boundary_;
  std::optional<NeighbourGrid<T>> fluid_grid_, boundary_grid_;
  GridGeometry<T> whole_grid_; // the grids' geometry on one rank: the domain's cells
  // solver.neighbour_list "on" or "verlet"; "verlet" lists reach skin_ past the support and are
  // kept, with the fluid's order and grid, over steps (SphLists).
  std::optional<SphLists<T>> fluid_list_;
  // The walls' builds (SphLists::walls_builds) whose lists a walls' pass has run over, writing
  // every wall: later passes over them skip the dry walls.
  std::uint64_t walls_written_ = ~std::uint64_t{0};
  double skin_ = 0;
  // The watchdog's sums (fluid, knit) and, on N ranks with fluid ghosts in the set, which rows
  // are owned (SimulationWatch.cpp).
  exec::DeviceBuffer<WatchSums> watch_sums_;
  // The work done from outside since this Simulation began, for the watchdog's energy budget
  // (docs/ARCHITECTURE.md, the watchdog): the moving solids' boundary forces on the fluid and the
  // moving handles' constraint in double (work_), the moving solids' contact corrections of
  // fluid and knit in fixed point of contact_unit_ joules (contact_work_, ContactWork). Sized 1
  // only where something moves (init_work_measures).
  exec::DeviceBuffer<double> work_{exec::Backend::Cpu, 0, "watchdog.work"};
  exec::DeviceBuffer<std::uint64_t> contact_work_{exec::Backend::Cpu, 0, "watchdog.work"};
  double contact_unit_ = 1.0;
  void init_work_measures();
  void init_contact_work(); // contact_work_ and its unit, where a solid moves
  /// The contact's work sink for a set of masses m (none where no solid moves).
  ContactWork<T> contact_work(const T* m) {
    if (contact_work_.size() == 0)
      return {};
    return {m, vec_cast<T>(scene_.gravity), contact_unit_, contact_work_.data()};
  }
  /// After the forces pass: the moving solids' boundary forces' work on the owned fluid over the
  /// step (sph_mover_work).
  void measure_boundary_work();
  /// The work measured so far [J], this rank's (watch() sums the job's).
  double work_done() const;
  MotionBounds<T> fluid_bounds_{}; // the fluid's speed and acceleration bounds at step start
  double fluid_step_motion() const;
  exec::DeviceBuffer<std::uint8_t> boundary_near_{exec::Backend::Cpu, 0, "boundary.near"};
  exec::DeviceBuffer<std::uint8_t> fluid_near_{exec::Backend::Cpu, 0, "fluid.near"};
  // knit, fluid, the job's fluid (N ranks planning on the device)
  exec::DeviceBuffer<MotionBounds<T>> bounds_{exec::Backend::Cpu, 0, "integrate.dt"};
  // bounds_[1] holds the fluid's bounds now, written by the last step's kick (kick_bounds): the
  // next stable_dt reads them instead of a pass of its own. Cleared when a step starts.
  bool fluid_bounds_ready_ = false;
  // A step planned on the device (fluid without knit, bounds from the last kick): the drift is
  // queued with the device's dt and the host collects the plan while it runs (settle_step). On
  // N ranks where the transport reduces device data (NCCL) the job's bounds are all-reduced
  // there first (bounds_[2]): no rank's host waits for the step size.
  FluidStepRule fluid_step_rule() const;
  /// The fluid's step size from its bounds (kept in fluid_bounds_; a non-finite one reported).
  double fluid_dt(const MotionBounds<T>& mb);
  // Knit scenes with fluid: the knit's and the fluid's bounds are queued when the step starts
  // and read while the stages before its size run (Pipeline::Stage::before_dt: the coupling's
  // saturation), so the device is not left idle while the host takes the size; settle_dt()
  // waits for them and takes it (a no-op when nothing is pending).
  bool reads_bounds_behind() const;
  void queue_both_bounds();
  double both_bounds_dt();
  void take_dt(double dt, double remaining); // dt_ and step_lands_; below dt_min reported
  void settle_dt();
  std::optional<exec::PendingRead<MotionBounds<T>>> bounds_read_;
  bool dt_pending_ = false;
  double dt_remaining_ = 0;
  bool plans_step_on_device() const;
  void settle_step();
  exec::DeviceBuffer<StepPlan<T>> plan_{exec::Backend::Cpu, 0, "integrate.dt"};
  std::optional<exec::PendingRead<StepPlan<T>>> plan_read_;
  bool step_pending_ = false, step_lands_ = false;
  const double* planned_dt() const { return step_pending_ ? &plan_.data()->dt : nullptr; }
  /// The fluid's lists for a neighbour pass: settled first (their check read back; SphLists).
  ListView<T> fluid_list_view() {
    if (!fluid_list_)
      return {};
    fluid_list_->settle(ex_);
    return fluid_list_->view();
  }
  // The job's split in space (more than one rank): migration, ghosts and their refreshes.
  std::optional<RankExchange<T>> ranks_;
  std::optional<KnitHalo<T>> knit_halo_;               // the knit's share and ghosts on N ranks
  std::optional<AbsorptionRanks<T>> absorption_ranks_; // the conserving absorption on N ranks
  /// The absorption's hooks on N ranks (collective), none on one rank.
  std::optional<AbsorptionSplit<T>> absorption_split() {
    if (!absorption_ranks_)
      return std::nullopt;
    return absorption_ranks_->split(ex_, *fluid_);
  }
  /// f() with the knit's ghosts present and current on N ranks (a pass that reads partners).
  template <typename F>
  void with_knit_ghosts(F&& f) {
    if (knit_halo_)
      knit_halo_->current();
    f();
  }
  /// The job's largest speed and acceleration on N ranks (max over ranks, NaN kept as inf).
  void job_bounds(MotionBounds<T>* mb, int n);

  /// Every knit point this rank holds (the whole knit before distribute).
  std::span<const Vec3<T>> all_knit_positions() {
    if (!knit_)
      return {};
    knit_host_.emplace(knit_->set().x); // a copy from a device, valid until the next call
    return knit_host_->span();
  }
  std::optional<HostValues<Vec3<T>>> knit_host_;
  RigidShapes<T> solids_; // the shapes table (host copy) and the mesh grids it points into
  exec::DeviceBuffer<RigidShape<T>> shapes_;
  Pipeline pipeline_;
};

} // namespace kf
