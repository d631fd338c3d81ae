#pragma once
// A running scene: the particle sets the scene's modules need, the pipeline of stages, and the
// adaptive time step. Precision is chosen at run time (SimulationT<float|double> behind this
// interface); the backend too.
#include "comm/MpiContext.hpp"
#include "domain/PartitionPlan.hpp"
#include "domain/Pipeline.hpp"
#include "domain/Scene.hpp"
#include "io/Frame.hpp"
#include "kernels/exec/Backend.hpp"

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace kf {

/// Whole-system figures for progress lines, snapshots and tests (host values).
struct Diagnostics {
  std::size_t fluid = 0, boundary = 0;
  double kinetic_energy = 0; // sum 1/2 m v^2 of fluid
  double max_speed = 0;
  double max_density_error = 0; // max (rho - rho0) / rho0 over fluid
  double mean_density_error = 0;
  double min_rigid_distance = 0;       // smallest signed distance of a fluid particle to any solid
  std::uint64_t guard_corrections = 0; // particles put back by the boundary guard, whole run
  std::uint64_t sheet_corrections = 0; // put back on their side of the knit's sheet, whole run
  std::uint64_t outflow_particles =
      0;                         // fluid removed after leaving through an open side, whole run
  double outflow_mass = 0;       // their mass [kg]
  std::uint64_t fluid_sorts = 0; // fluid grid sorts (with "verlet" lists: list builds), whole run
  // "verlet" lists, whole run: builds because a particle moved farther than the skin [m], and
  // because pairs may have closed in by more than it (the rest: forced, or the first).
  std::uint64_t list_ends_far = 0, list_ends_sheared = 0;
  double list_skin = 0;
  // Knit (zero when the scene has none).
  std::size_t knit = 0;
  double knit_kinetic_energy = 0, knit_elastic_energy = 0, knit_potential_energy = 0; // [J]
  std::uint64_t knit_contacts = 0;      // point-substeps in contact with a solid, whole run
  double knit_min_rigid_distance = 0;   // smallest signed distance of a knit point to a solid
  std::uint64_t knit_self_contacts = 0; // overlapping point pairs now (self-collision)
  double knit_self_energy = 0;          // their penalty energy [J]
  double knit_self_min_gap = 0;         // closest pair distance / 2R (1e30 when none in reach)
  // Knit-fluid coupling (zero without modules contact / capillary).
  std::uint64_t coupling_contacts = 0; // fluid-knit pairs within the contact reach now
  double coupling_energy = 0;          // their penalty energy [J]
  // Fluid particles near the knit at a recent build of the coupling's lists: its lists' rows
  // (KnitFluidCoupling::near_particles; summed over ranks, ghosts on each).
  std::uint64_t coupling_rows = 0;
  // Builds of the coupling's lists, whole run (this rank's; with "verlet" lists they last until
  // the fluid's or the knit grid's next sort, on N ranks as on one).
  std::uint64_t coupling_list_builds = 0;
  double absorbed_mass = 0; // sum of the knit points' m_fluid [kg]
  double max_saturation = 0, mean_saturation = 0;
  std::uint64_t wet_points = 0; // knit points with s > 0.01
  double fluid_mass = 0;        // sum of the free fluid particles' masses [kg]
  // Mass-conserving absorption (capillary.model = "conserving"), whole run.
  std::uint64_t absorbed_particles = 0, emitted_particles = 0;
  // Several ranks: the compute imbalance measured at the last check (slowest over the mean), the
  // re-partitions so far, the checks past the threshold where one would not have paid
  // ([parallel] payback: its time would not come back, or the particles' counts were balanced
  // already, `balanced_declines` of them, the counted imbalance at the last check that counted
  // `counted_imbalance`, the largest among those declines `declined_counted`), and what the last
  // one cost (the slowest rank's seconds; METIS's part).
  double imbalance = 0, counted_imbalance = 0, declined_counted = 0;
  double phase_imbalance = 0; // each phase's slowest rank summed, over the mean (the waits' bound)
  // Each phase's slowest rank over that phase's mean (fluid, boundary, knit; 0: not timed apart).
  std::array<double, kPhases> phase_spread{};
  double pair_weight = 0; // a knit-fluid coupling pair's measured cost in knit points (0: not yet)
  std::uint64_t repartitions = 0, declined_repartitions = 0, balanced_declines = 0;
  double repartition_seconds = 0, partition_seconds = 0;
  double diffused_mass = 0; // moved between knit points [kg]
};

/// What `knitflow plan` prints: computed from the scene alone, nothing allocated or run.
struct PlanReport {
  std::vector<std::pair<std::string, std::string>> stages; // (name [module], what)
  std::size_t fluid = 0, boundary = 0, knit = 0, springs = 0, volume_cells = 0;
  double knit_self_radius = 0;   // R of knit self-collision (0: off)
  double coupling_reach = 0;     // fluid-knit contact distance R_f + R_k (0: no coupling)
  double coupling_stiffness = 0; // its k [N/m] (0: no contact module)
  double support_radius = 0;
  int grid[3] = {0, 0, 0};
  std::size_t bytes_fluid = 0, bytes_boundary = 0, bytes_grid = 0, bytes_knit = 0;
  std::size_t bytes_solids = 0; // sampled signed distances of mesh obstacles
  // Of bytes_knit: the springs' and cells' rows (a rank of N holds them for its owned points);
  // the rest is a point's, owned or ghost (its state, the self-contact's copies and grid).
  std::size_t bytes_knit_rows = 0;
  std::size_t grid_bytes_per_cell = 0; // the fluid's and the boundary's grids together
  // The fluid's neighbour lists (solver.neighbour_list on), at the start: their rows as wide as
  // the build makes them for the densest row of the lattice (`list_most` particles within the
  // support and the skin; a wall's, `wall_list_most`, the fluid over a flat wall); bytes a fluid
  // particle and a boundary particle.
  std::size_t bytes_lists = 0;
  std::uint32_t list_most = 0, wall_list_most = 0;
  // The knit-fluid coupling once its lists are built (KnitFluidCoupling::footprint): its grid's
  // tables over the domain (whole on every rank), bytes a fluid particle, a knit point and a row
  // of its lists, one a fluid particle near the knit (`coupling_near`, KnitFluidCoupling::
  // near_bound: the fluid around the knit at rest, at its lattice spacing).
  std::size_t bytes_coupling = 0, coupling_bytes_grid = 0, coupling_near = 0;
  std::size_t coupling_bytes_fluid = 0, coupling_bytes_knit = 0, coupling_bytes_row = 0;
  double list_bytes_fluid = 0, list_bytes_boundary = 0;
  std::vector<std::string> obstacles; // one line per obstacle: name, shape, mesh details
  double initial_dt = 0;
  std::string dt_limit; // which condition sets the initial dt
  // The run's typical dt (the CFL condition at the fluid's fall speed from its top, zero for a
  // scene settling under damping) and end_time over it: the cost model's steps.
  double fall_speed = 0, run_dt = 0, run_steps = 0;
  // The conserving absorption's Darcy substeps in a step of run_dt (0 without it), and the
  // snapshots the run writes (0 with output off): the cost model's.
  double darcy_substeps = 0, output_frames = 0;

  /// What the ranks share between them (the solids' sampled distances are held whole by each).
  std::size_t bytes_shared() const {
    return bytes_fluid + bytes_boundary + bytes_grid + bytes_knit + bytes_lists + bytes_coupling;
  }
  /// The one-rank total, solids included.
  std::size_t bytes() const { return bytes_shared() + bytes_solids; }
};

/// What a rank of plan_split's holds of plan's memory (`knitflow plan --ranks N`, the same
/// measure as PlanReport's bytes on one rank, Simulation::memory_bytes on a run's rank): each
/// phase's bytes a particle times the rank's owned and ghost particles (the knit's rows for its
/// owned points only), its grids' window, and what every rank of N holds whole (the solids'
/// table; for the knit an id -> local index a point and a slot a volume cell).
double rank_bytes(const PlanReport& r, const RankShare& s, int ranks);

/// What the watchdog reads every few dozen steps (domain/Watchdog), the job's: one pass over
/// each set on the device and one small read (and on N ranks one reduction).
struct WatchReading {
  double mass = 0;      // fluid and knit (dry) [kg]
  double knit_mass = 0; // the knit's (dry) [kg]
  double kinetic = 0;   // fluid and knit, sum 1/2 m v^2 [J]
  double potential = 0; // fluid and knit, sum m |g| height above the domain's lowest corner [J]
  double fluid_max_speed = 0, fluid_max_density = 0, knit_max_speed = 0; // NaN: not finite
  // The work done on the particles from outside since the Simulation was made (moving solids,
  // moving handles) [J]; 0 where nothing moves.
  double work = 0;
};
/// The measures the watchdog bounds, each of one particle.
enum class WatchMeasure { FluidSpeed, FluidDensity, KnitSpeed };

class Simulation {
public:
  /// The stages, particle counts, memory and initial dt of a scene, without running it.
  static PlanReport plan(const Scene& scene);
  /// The split over `ranks` a run of the scene starts with, and what each rank owns and receives
  /// (`knitflow plan --ranks N`): the particles, knit and coupling built on the host as a run
  /// builds them (no forces evaluated), split by the run's rules (RankLayout).
  static PartitionReport plan_split(const Scene& scene, int ranks);

  virtual ~Simulation() = default;

  /// Builds the particle sets and the pipeline for the scene and evaluates the initial forces.
  /// With `mpi` of more than one rank the domain is split among its ranks (RankExchange): each
  /// holds the particles it owns, and diagnostics() and frame() are collective.
  static std::unique_ptr<Simulation> create(const Scene& scene, exec::Backend backend,
                                            const comm::MpiContext* mpi = nullptr);

  /// Advances one step of the adaptive size, never past `t_limit`; returns the dt taken.
  virtual double step(double t_limit) = 0;
  virtual double time() const = 0;
  virtual std::uint64_t steps() const = 0;
  /// The dt the next step would take if nothing limited it (CFL, force, viscous, dt_max).
  virtual double stable_dt() = 0;

  /// Full state (every field needed to continue bit for bit) as a snapshot frame.
  virtual io::Frame frame() const = 0;
  /// Continues from a frame written by frame() of a run of the same scene.
  virtual void restore(const io::Frame& frame) = 0;

  virtual Diagnostics diagnostics() const = 0;
  /// The watchdog's reading (collective on N ranks).
  virtual WatchReading watch() = 0;
  /// The particle with the largest measure (NaN counts as largest), the job's: its phase, id,
  /// position, speed (and density), and its neighbourhood within the support radius (how many,
  /// their speeds and densities). For the watchdog's report; collective, the text on every rank
  /// ("" when no rank holds a particle of that set).
  virtual std::string describe_worst(WatchMeasure measure) const = 0;
  virtual const Pipeline& pipeline() const = 0;
  virtual const Scene& scene() const = 0;
  virtual exec::Backend backend() const = 0;
  /// Device memory held by particle sets and grids, in bytes.
  virtual std::size_t memory_bytes() const = 0;
  /// Several ranks: the rank count, the compute imbalance at the last check and this rank's
  /// seconds in the split's exchanges (migration, ghosts, refreshes) so far, and of them those
  /// of the fluid's migration and ghosts, the ghost refreshes, the re-partitions, and the
  /// packing (in all of these); ranks 1 otherwise.
  struct RankReport {
    int ranks = 1;
    double imbalance = 0, exchange_seconds = 0;
    double migration_seconds = 0, refresh_seconds = 0, rebalance_seconds = 0, packing_seconds = 0;
    double reduction_seconds = 0; // the step size's all-reduce (the wait for the slowest rank)
    std::string transport;        // "mpi", "nccl" or "ipc"
    // With profile_on_device: the density's, the walls' and the forces' passes and the exchange
    // after each, on the device (seconds from the start, not synchronised).
    std::array<double, 3> refresh_pass_device{}, refresh_exchange_device{};
    // This rank's fluid (or boundary) grid: its cells and the whole domain's (a rank's grid
    // covers its region, NeighbourGrid::within; 0 without either set).
    std::uint64_t grid_cells = 0, domain_cells = 0;
    std::array<std::uint64_t, 3> owned{}; // particles this rank owns: fluid, boundary, knit
  };
  virtual RankReport rank_report() const { return {}; }
  /// Measure each stage's time (synchronising the device after each stage).
  virtual void set_profiling(bool on) = 0;
  /// Time each stage on the device as well, without synchronising (Pipeline::time_on_device);
  /// read with collect_device_profile() before the stages' times are.
  virtual void profile_on_device() = 0;
  virtual void collect_device_profile() = 0;
};

} // namespace kf
