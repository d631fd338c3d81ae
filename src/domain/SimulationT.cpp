// SimulationT<T>: the fluid + boundary pipeline of P1 in precision T on one backend.
#include "core/Error.hpp"
#include "domain/AbsorptionRanks.hpp"
#include "domain/FrameFields.hpp"
#include "domain/KnitBuilder.hpp"
#include "domain/KnitHalo.hpp"
#include "domain/KnitSystem.hpp"
#include "domain/MeshObstacle.hpp"
#include "domain/RankExchange.hpp"
#include "domain/RigidShapes.hpp"
#include "domain/Samplers.hpp"
#include "domain/Simulation.hpp"
#include "domain/StageParts.hpp"
#include "kernels/boundary/Boundary.hpp"
#include "kernels/coupling/Absorption.hpp"
#include "kernels/coupling/KnitFluidCoupling.hpp"
#include "kernels/exec/PendingRead.hpp"
#include "kernels/grid/NeighbourGrid.hpp"
#include "kernels/grid/NeighbourList.hpp"
#include "kernels/integrate/StepSize.hpp"
#include "kernels/integrate/Verlet.hpp"
#include "kernels/particles/FluidSet.hpp"
#include "kernels/particles/Outflow.hpp"
#include "kernels/sph/Sph.hpp"
#include "kernels/sph/SphLists.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>
#include <sstream>
#include <type_traits>
#include <vector>

namespace kf {

/// The coupling's parameters from the scene (docs/PHYSICS.md "Coupling"): contact reach
/// R_fluid + R_knit, stiffness that stops a fluid particle arriving at a tenth of the sound
/// speed within half the reach, and the capillary pressure scale sigma / sqrt(kappa / phi).
/// knit_spacing: the knit's widest point spacing; the default R_knit makes the reach 0.8 of it,
/// so no fluid particle fits through the gap between four points of a sheet (0.71 of it).
template <typename T>
CouplingParams<T> coupling_params(const Scene& s, double knit_spacing) {
  CouplingParams<T> p;
  p.contact = s.has(Module::Contact);
  p.capillary = s.has(Module::Capillary);
  p.capillary_force = s.capillary.model == Scene::AbsorptionModel::Paper;
  const double rf = s.coupling.fluid_radius > 0 ? s.coupling.fluid_radius : 0.5 * s.fluid.spacing;
  const double rk = s.coupling.knit_radius > 0 ? s.coupling.knit_radius
                                               : std::max(s.knit.radius(), 0.8 * knit_spacing - rf);
  const double reach = rf + rk;
  const double mf = lattice_particle_mass(s.solver.kernel, s.fluid.support, s.fluid.spacing,
                                          s.fluid.rest_density);
  const double c = s.fluid.speed_of_sound;
  const double k = s.coupling.stiffness > 0 ? s.coupling.stiffness
                                            : mf * (0.1 * c) * (0.1 * c) / (0.25 * reach * reach);
  p.reach = static_cast<T>(reach);
  p.dem = {static_cast<T>(k), static_cast<T>(s.coupling.damping_ratio),
           static_cast<T>(s.coupling.friction)};
  p.h = static_cast<T>(s.support_radius());
  p.porosity = static_cast<T>(s.capillary.porosity);
  p.rho0 = static_cast<T>(s.fluid.rest_density);
  p.pressure_scale = static_cast<T>(s.capillary.sigma /
                                    std::sqrt(s.capillary.permeability / s.capillary.porosity));
  p.volume_per_mass = static_cast<T>(s.knit.thickness / s.knit.mass_per_area);
  p.gravity = vec_cast<T>(s.gravity);
  return p;
}

/// The scene's equation of state, in the precision U.
template <typename U>
Eos<U> scene_eos(const Scene& s) {
  return {s.fluid.eos, static_cast<U>(s.fluid.rest_density),
          static_cast<U>(s.fluid.speed_of_sound * s.fluid.speed_of_sound),
          static_cast<U>(s.fluid.tait_exponent), s.fluid.clamp_negative_pressure};
}

namespace {

/// Restart state of a grid kept over steps (SkinWatch::State) in a snapshot: its sorted
/// positions as the field `name`_sorted_position of phase p, its device record and host bound as
/// the scalars `name`_moved2 and `name`_bound.
template <typename T>
void put_watch(io::Frame& fr, io::Phase& p, const std::string& name,
               const typename SkinWatch<T>::State& s, bool split = false) {
  if (s.x0.empty() && !split)
    return; // never sorted (on N ranks a rank may hold no point: every rank writes the field)
  p.fields.push_back(io::Field::from(name + "_sorted_position", flatten(s.x0), 3));
  fr.scalars.push_back({name + "_moved2", static_cast<double>(s.moved2)});
  fr.scalars.push_back({name + "_bound", static_cast<double>(s.bound)});
}

const double* find_scalar(const io::Frame& fr, const std::string& name) {
  for (const auto& [k, v] : fr.scalars)
    if (k == name)
      return &v;
  return nullptr;
}

/// put_watch's state back; none when the snapshot lacks it (written without the grid, or by an
/// older knitflow).
template <typename T>
std::optional<typename SkinWatch<T>::State> get_watch(const io::Frame& fr, const io::Phase& p,
                                                      const std::string& name) {
  const io::Field* x0 = p.find(name + "_sorted_position");
  const double* moved2 = find_scalar(fr, name + "_moved2");
  const double* bound = find_scalar(fr, name + "_bound");
  if (!x0 || !moved2 || !bound)
    return std::nullopt;
  return typename SkinWatch<T>::State{unflatten(x0->as<T>()), static_cast<T>(*moved2),
                                      static_cast<T>(*bound)};
}

/// Times a pass of local work (one that waits for no other rank) for the ranks' imbalance, until
/// stop() or the end of the scope; nothing on one rank. On a device the time is the stream's
/// between two events, read at the imbalance check: the host does not wait for the pass here.
template <typename T>
class LocalWork {
public:
  explicit LocalWork(RankExchange<T>* ranks, Phase phase = Phase::Fluid)
      : ranks_(ranks), phase_(phase), exchange0_(ranks ? ranks->exchange_seconds() : 0.0) {
    if (ranks_)
      ranks_->clock(phase_).start();
  }
  ~LocalWork() { stop(); }
  void stop() const {
    if (!ranks_)
      return;
    ranks_->clock(phase_).stop();
    // Less the exchanges inside the scope (the knit's ghost refreshes between substeps, timed
    // on the host: each waits for its rows, so the device idles for about as long).
    const double waited = ranks_->exchange_seconds() - exchange0_;
    if (waited > 0)
      ranks_->add_compute(-waited, phase_);
    ranks_ = nullptr;
  }

private:
  mutable RankExchange<T>* ranks_;
  Phase phase_;
  double exchange0_;
};

/// Keeps the rows of every field of p whose mask entry is nonzero.
void keep_rows(io::Phase& p, const std::vector<std::uint8_t>& mask) {
  for (io::Field& f : p.fields) {
    const std::size_t row = f.bytes.size() / std::max<std::size_t>(1, f.count);
    std::vector<unsigned char> kept;
    kept.reserve(f.bytes.size());
    std::size_t n = 0;
    for (std::size_t i = 0; i < f.count; ++i)
      if (mask[i]) {
        kept.insert(kept.end(), f.bytes.begin() + i * row, f.bytes.begin() + (i + 1) * row);
        ++n;
      }
    f.bytes = std::move(kept);
    f.count = n;
  }
}

/// The phase's rows in the order of its "id" field (a snapshot written by N ranks holds each
/// rank's rows in turn).
void rows_by_id(io::Phase& p) {
  const io::Field* idf = p.find("id");
  if (!idf)
    throw Error("restart: the snapshot's " + p.name + " phase has no id field");
  const auto id = idf->as<std::uint64_t>();
  std::vector<std::size_t> order(id.size());
  for (std::size_t k = 0; k < order.size(); ++k)
    order[k] = k;
  if (std::is_sorted(id.begin(), id.end()))
    return;
  std::sort(order.begin(), order.end(), [&](auto a, auto b) { return id[a] < id[b]; });
  for (io::Field& f : p.fields) {
    if (f.count != id.size())
      continue;
    const std::size_t row = f.bytes.size() / std::max<std::size_t>(1, f.count);
    std::vector<unsigned char> out(f.bytes.size());
    for (std::size_t k = 0; k < order.size(); ++k)
      std::copy_n(f.bytes.begin() + order[k] * row, row, out.begin() + k * row);
    f.bytes = std::move(out);
  }
}

/// out[k] = v[perm[k]]: a host copy put in a sort's order.
template <typename U>
std::vector<U> permuted(const std::vector<U>& v, const std::vector<std::uint32_t>& perm) {
  std::vector<U> out(perm.size());
  for (std::size_t k = 0; k < perm.size(); ++k)
    out[k] = v[perm[k]];
  return out;
}

} // namespace

/// Explicit contact: the knit's substep and the fluid's step each resolve the contact's
/// oscillation for their own mass, with up to kMaxContacts partners at once.
struct CouplingLimits {
  double knit_substep = 1e30, fluid_step = 1e30;
};
CouplingLimits coupling_limits(const Scene& s, double k, double knit_min_mass) {
  constexpr double kMaxContacts = 6;
  const double factor = s.knit.spring_factor;
  const double mf = lattice_particle_mass(s.solver.kernel, s.fluid.support, s.fluid.spacing,
                                          s.fluid.rest_density);
  return {factor * std::sqrt(knit_min_mass / (kMaxContacts * k)),
          factor * std::sqrt(mf / (kMaxContacts * k))};
}

template <typename T>
class SimulationT final : public Simulation {
public:
  SimulationT(const Scene& scene, exec::Backend backend, bool plan_only = false,
              const comm::MpiContext* mpi = nullptr);

  double step(double t_limit) override;
  double time() const override { return time_; }
  std::uint64_t steps() const override { return steps_; }
  double stable_dt() override;
  io::Frame frame() const override;
  void restore(const io::Frame& frame) override;
  Diagnostics diagnostics() const override;
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
            std::string(ranks_->transport_name())};
  }
  void set_profiling(bool on) override {
    profiling_ = on;
    stage_parts::enable(on, ex_.backend);
  }

private:
  void build_pipeline();
  void init_particles();
  void init_coupling();
  void init_absorption(const CouplingParams<T>& cp);
  void update_shapes(double t);
  /// remove_outflow: the fluid outside the domain is removed in the same sort (counted).
  /// acceleration false: a is not carried (a forces pass follows before anything reads it).
  void sort_fluid(bool remove_outflow = false, typename FluidSet<T>::Carry carry = {});
  void sort_boundary();
  /// Restart: the fluid's grid (and lists) as the run that wrote fr holds them (see restore).
  void restore_fluid_grid(const io::Frame& fr);
  void compute_forces();
  /// The sph.density and sph.forces stages for a step of dt (0: at t = 0).
  void fluid_density(T dt);
  bool density_done_ = false; // this step's sph.density ran early (while the lists were read)
  void fluid_forces(T dt);
  bool continuity() const { return scene_.solver.density == DensityModel::Continuity; }
  BoundaryNeighbours<T> boundary_neighbours();
  void extrapolate_boundary_pressure();
  /// Velocity factor of one half kick of a step h: exp(-zeta h / 2) while settling, else 1.
  T damping_keep(double h) const {
    const auto& s = scene_.solver;
    return (s.damping > 0 && time_ < s.damping_until)
               ? static_cast<T>(std::exp(-0.5 * s.damping * h))
               : T(1);
  }
  [[noreturn]] void report_instability(const std::string& why);

  Scene scene_;
  exec::Exec ex_;
  bool fluid_on_ = false, boundary_on_ = false, knit_on_ = false, moving_ = false;
  bool coupling_on_ = false;
  double coupling_fluid_limit_ = 1e30; // fluid step bound from the knit-fluid contact
  FluidSide<T> fluid_side() { return {fluid_->view(), fluid_grid_->view()}; }
  SphParams<T> sph_;
  double h_ = 0, margin_ = 0;
  double time_ = 0, dt_ = 0;
  std::uint64_t steps_ = 0;
  // Particles put back by the guard, whole run: a counter in device memory, read only for
  // snapshots and diagnostics so the step never waits for it.
  exec::DeviceBuffer<std::uint64_t> guard_count_{exec::Backend::Cpu, 0, "boundary.guard_count"};
  std::uint64_t guard_corrections() const { return guard_count_.to_host()[0]; }
  std::uint64_t outflow_particles_ = 0, fluid_sorts_ = 0;
  double outflow_mass_ = 0; // removed before the restart this run started from (its snapshot's)
  // The mass removed by sorts since (sort_removing_outside), summed on the device: read with the
  // diagnostics, not at every sort.
  exec::DeviceBuffer<double> sorted_outflow_mass_{exec::Backend::Cpu, 0, "fluid.outflow"};
  double outflow_mass() const { return outflow_mass_ + sorted_outflow_mass_.to_host()[0]; }
  bool profiling_ = false;

  std::optional<KnitSystem<T>> knit_;
  std::optional<KnitFluidCoupling<T>> coupling_;
  std::optional<ConservingAbsorption<T>> absorption_; // capillary.model = "conserving"
  std::uint64_t next_fluid_id_ = 0;
  void begin_coupling() {
    if (knit_halo_) { // the knit's ghosts current, and their saturation their owners'
      stage_parts::Scope part("coupling.begin: knit ghosts (refreshed, or chosen anew)");
      knit_halo_->begin(knit_->expected_motion(dt_));
    }
    coupling_->begin_step(ex_, knit_->set(), fluid_side(),
                          absorption_ ? absorption_->absorbed().data() : nullptr,
                          absorption_ ? absorption_->capacity().data() : nullptr,
                          static_cast<T>(knit_->expected_motion(dt_)), share_saturation());
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
      coupling_->update_saturation(
          ex_, knit_->set(), fluid_side(), absorption_ ? absorption_->absorbed().data() : nullptr,
          absorption_ ? absorption_->capacity().data() : nullptr, share_saturation());
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
  // solver.neighbour_list "on" or "verlet"; "verlet" lists reach skin_ past the support and are
  // kept, with the fluid's order and grid, over steps (SphLists).
  std::optional<SphLists<T>> fluid_list_;
  double skin_ = 0;
  MotionBounds<T> fluid_bounds_{}; // the fluid's speed and acceleration bounds at step start
  double fluid_step_motion() const;
  exec::DeviceBuffer<std::uint8_t> boundary_near_{exec::Backend::Cpu, 0, "boundary.near"};
  exec::DeviceBuffer<std::uint8_t> fluid_near_{exec::Backend::Cpu, 0, "fluid.near"};
  exec::DeviceBuffer<MotionBounds<T>> bounds_{exec::Backend::Cpu, 0, "integrate.dt"}; // knit, fluid
  // bounds_[1] holds the fluid's bounds now, written by the last step's kick (kick_bounds): the
  // next stable_dt reads them instead of a pass of its own. Cleared when a step starts.
  bool fluid_bounds_ready_ = false;
  // A step planned on the device (fluid without knit, bounds from the last kick): the drift is
  // queued with the device's dt and the host collects the plan while it runs (settle_step).
  FluidStepRule fluid_step_rule() const;
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
  void job_bounds(MotionBounds<T>* mb, int n) const;

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

template <typename T>
SimulationT<T>::SimulationT(const Scene& scene, exec::Backend backend, bool plan_only,
                            const comm::MpiContext* mpi)
    : scene_(scene), ex_{backend}, guard_count_(backend, 0, "boundary.guard_count"),
      sorted_outflow_mass_(backend, 0, "fluid.outflow"),
      boundary_near_(backend, 0, "boundary.near"), fluid_near_(backend, 0, "fluid.near"),
      bounds_(backend, 2, "integrate.dt"), plan_(backend, 1, "integrate.dt"),
      solids_(scene, backend), shapes_(backend, 0, "rigid.shapes") {
  guard_count_.assign(std::vector<std::uint64_t>{0});
  sorted_outflow_mass_.assign(std::vector<double>{0.0});
  fluid_on_ = scene.has(Module::Fluid);
  boundary_on_ = scene.has(Module::Boundary);
  knit_on_ = scene.has(Module::Knit);
  coupling_on_ =
      fluid_on_ && knit_on_ && (scene.has(Module::Contact) || scene.has(Module::Capillary));
  h_ = scene.support_radius();
  if (scene.solver.neighbour_list == Scene::Solver::NeighbourLists::Verlet)
    skin_ = scene.solver.neighbour_skin * h_;
  // Only a true crossing is corrected: near a wall at the free surface the pressure is zero and
  // particles may touch the wall, which is physical.
  margin_ = 0.01 * scene.fluid.spacing;
  for (const auto& o : scene.obstacles)
    if (o.velocity.x != 0 || o.velocity.y != 0 || o.velocity.z != 0)
      moving_ = true;

  sph_.kernel = scene.solver.kernel;
  sph_.h = static_cast<T>(h_);
  sph_.eos = scene_eos<T>(scene);
  sph_.viscosity = static_cast<T>(scene.fluid.viscosity);
  sph_.no_slip = scene.fluid.no_slip;
  sph_.gravity = vec_cast<T>(scene.gravity);
  sph_.density = scene.solver.density;
  sph_.diffusion =
      static_cast<T>(scene.solver.density_diffusion * 0.5 * h_ * scene.fluid.speed_of_sound);

  build_pipeline();
  if (plan_only)
    return; // the stage list is all `plan` needs
  init_particles();
  update_shapes(0.0);
  // On N ranks each keeps what it owns (every rank sampled the whole scene above).
  if (mpi && mpi->size() > 1) {
    const KnitFluidCoupling<T>* c = coupling_ ? &*coupling_ : nullptr;
    const double reach =
        c ? std::max(double(coupling_reach(c->params())), c->params().capillary ? h_ : 0.0) : 0.0;
    // With the coupling, a knit point may stray half the knit's skin (one support radius)
    // outside the region it is owned by until its ghosts are chosen anew: the fluid's ghosts
    // reach that much farther.
    const double knit_skin = c ? h_ : 0.0;
    ranks_.emplace(*mpi, scene_, backend, knit_ ? KnitHalo<T>::base_width(*knit_, c) : 0.0,
                   c ? reach + 0.5 * knit_skin : 0.0, skin_);
    if (fluid_list_) // every rank keeps or builds its lists at the same steps
      fluid_list_->combine_readings([this](T* m, int k) {
        MPI_Allreduce(MPI_IN_PLACE, m, k, std::is_same_v<T, float> ? MPI_FLOAT : MPI_DOUBLE,
                      MPI_MAX, ranks_->mpi().comm());
      });
    ranks_->distribute(fluid_ ? &*fluid_ : nullptr, boundary_ ? &*boundary_ : nullptr,
                       all_knit_positions());
    if (knit_) {
      knit_halo_.emplace(*ranks_, *knit_, coupling_ ? &*coupling_ : nullptr, knit_skin);
      if (absorption_)
        absorption_ranks_.emplace(*ranks_, *knit_halo_, *knit_, *absorption_);
      knit_halo_->distribute();
    }
  }
  if (boundary_on_)
    sort_boundary();
  if (knit_on_)
    with_knit_ghosts([this] { knit_->compute_forces(); });
  if (fluid_on_) {
    sort_fluid(false, {false}); // a: written next
    compute_forces();           // a(t = 0), which the first half kick needs
    if (ranks_ && coupling_on_) // the ghosts the coupling reads take their owners' a
      ranks_->refresh_motion(*fluid_);
  }
  if (coupling_on_)
    begin_coupling(); // saturation at t = 0, for snapshots and diagnostics before a step
}

template <typename T>
void SimulationT<T>::init_particles() {
  const auto& d = scene_.domain;
  if (knit_on_)
    knit_.emplace(scene_, ex_);
  if (fluid_on_) {
    const FluidSamples fs = sample_fluid(scene_);
    const auto& x = fs.x;
    const double m = lattice_particle_mass(scene_.solver.kernel, scene_.fluid.support,
                                           scene_.fluid.spacing, scene_.fluid.rest_density);
    std::vector<Vec3<T>> xs(x.size()), vs(x.size());
    std::vector<std::uint64_t> ids(x.size());
    for (std::size_t i = 0; i < x.size(); ++i) {
      xs[i] = vec_cast<T>(x[i]);
      vs[i] = vec_cast<T>(fs.v[i]);
      ids[i] = i;
    }
    fluid_.emplace(ex_.backend);
    fluid_->resize(x.size());
    fluid_->x.assign(xs);
    fluid_->v.assign(vs);
    fluid_->a.assign(std::vector<Vec3<T>>(x.size(), Vec3<T>{}));
    fluid_->m.assign(std::vector<T>(x.size(), static_cast<T>(m)));
    // The continuity equation's start (summation recomputes the density).
    std::vector<T> rho(x.size(), static_cast<T>(scene_.fluid.rest_density));
    if (continuity() && scene_.fluid.initial_density == Scene::Fluid::InitialDensity::Hydrostatic) {
      const auto h =
          hydrostatic_density(fs, scene_.gravity, scene_.fluid.spacing, scene_eos<double>(scene_));
      for (std::size_t i = 0; i < h.size(); ++i)
        rho[i] = static_cast<T>(h[i]);
    }
    fluid_->rho.assign(rho);
    fluid_->drho.assign(std::vector<T>(x.size(), T(0)));
    fluid_->drho_prev.assign(std::vector<T>(x.size(), T(0)));
    fluid_->id.assign(ids);
    next_fluid_id_ = ids.size();
    const int span = static_cast<int>(scene_.solver.cell_span);
    // Cells reach the support plus the lists' skin: a walk of the grid then stays exact between
    // the lists' builds (no point has moved more than the skin since the sort; SphLists).
    fluid_grid_.emplace(ex_.backend,
                        NeighbourGrid<T>::cover(d.min, d.max, (h_ + skin_) / span, span), span,
                        static_cast<int>(scene_.solver.cell_order));
    if (scene_.solver.neighbour_list != Scene::Solver::NeighbourLists::Off)
      fluid_list_.emplace(ex_.backend, static_cast<T>(skin_));
  }
  if (boundary_on_) {
    const auto s = sample_boundaries(scene_, scene_.fluid.spacing, h_);
    // Lattice particles: each stands for the volume of one lattice site, 1 / sum W.
    const double volume = lattice_particle_mass(scene_.solver.kernel, scene_.fluid.support,
                                                scene_.fluid.spacing, 1.0);
    std::vector<Vec3<T>> xs(s.x.size());
    std::vector<T> vol(s.x.size());
    std::vector<std::uint64_t> ids(s.x.size());
    for (std::size_t i = 0; i < s.x.size(); ++i) {
      xs[i] = vec_cast<T>(s.x[i]);
      vol[i] = static_cast<T>(volume * s.volume_scale[i]);
      ids[i] = i;
    }
    boundary_.emplace(ex_.backend);
    boundary_->resize(xs.size());
    boundary_->x.assign(xs);
    boundary_->x0.assign(xs);
    boundary_->obstacle.assign(s.obstacle);
    boundary_->volume.assign(vol);
    boundary_->id.assign(ids);
    const int span = static_cast<int>(scene_.solver.cell_span);
    boundary_grid_.emplace(ex_.backend,
                           NeighbourGrid<T>::cover(d.min, d.max, (h_ + skin_) / span, span), span,
                           static_cast<int>(scene_.solver.cell_order));
  }
  if (coupling_on_)
    init_coupling();
}

template <typename T>
void SimulationT<T>::init_absorption(const CouplingParams<T>& cp) {
  // Pore links: in-layer stretch springs and the straight springs between layers. Conductance
  // rho0 kappa / mu times the link's cross-section over its length, (V_i + V_j) / (2 L^2)
  // (exact for a grid's u and v links: V / a^2 = b t / (3 a)).
  const KnitMesh mesh = build_knit(scene_);
  const double vpm = scene_.knit.thickness / scene_.knit.mass_per_area;
  const double rho0 = scene_.fluid.rest_density, phi = scene_.capillary.porosity;
  const double darcy =
      rho0 * scene_.capillary.permeability / std::max(scene_.fluid.viscosity, 1e-6);
  std::vector<std::array<std::uint32_t, 2>> links;
  std::vector<double> conductance;
  for (const Spring& sp : mesh.springs)
    if (sp.kind == SpringKind::Stretch || sp.kind == SpringKind::VolumeStraight) {
      links.push_back({sp.i, sp.j});
      conductance.push_back(darcy * (mesh.m[sp.i] + mesh.m[sp.j]) * vpm / (2 * sp.rest * sp.rest));
    }
  std::vector<T> dry(mesh.m.size()), capacity(mesh.m.size());
  for (std::size_t i = 0; i < dry.size(); ++i) {
    dry[i] = static_cast<T>(mesh.m[i]);
    capacity[i] = static_cast<T>(phi * mesh.m[i] * vpm * rho0);
  }
  AbsorptionParams<T> ap;
  ap.reach = cp.reach;
  ap.emit_saturation = static_cast<T>(scene_.capillary.emit_saturation);
  ap.drop_mass = static_cast<T>(lattice_particle_mass(scene_.solver.kernel, scene_.fluid.support,
                                                      scene_.fluid.spacing, rho0));
  ap.min_particle_mass = static_cast<T>(0.1 * double(ap.drop_mass));
  ap.drop_offset = static_cast<T>(double(cp.reach) + scene_.knit.thickness);
  const double g = norm(scene_.gravity);
  ap.down = g > 0 ? vec_cast<T>(scene_.gravity * (1 / g)) : Vec3<T>{T(0), T(0), T(-1)};
  ap.gravity = vec_cast<T>(scene_.gravity);
  ap.rho0 = static_cast<T>(rho0);
  ap.pressure_scale = cp.pressure_scale;
  absorption_.emplace(ex_.backend, ap, dry, capacity, links, conductance);
}

template <typename T>
void SimulationT<T>::init_coupling() {
  const CouplingParams<T> p = coupling_params<T>(scene_, knit_->longest_spacing());
  const double reach = std::max(double(p.reach), p.capillary ? h_ : 0.0);
  // The coupling walks the fluid's grid, which "verlet" lists sort only now and then: a walk
  // finds every particle within h of a point (SphLists), so the reach must fit in that.
  if (skin_ > 0 && reach > h_)
    throw Error("solver.neighbour_list = \"verlet\": the knit-fluid coupling reaches " +
                std::to_string(reach) + " m, more than the fluid's support (" + std::to_string(h_) +
                " m); use neighbour_list = \"off\"");
  // Cells 50% over the reach: a third of the margin is the grid's skin (it is sorted again when a
  // point moved that far), two thirds the per-step lists' (KnitFluidCoupling).
  coupling_.emplace(ex_.backend, scene_.solver.kernel, p,
                    NeighbourGrid<T>::cover(scene_.domain.min, scene_.domain.max, 1.5 * reach));
  if (p.capillary && scene_.capillary.model == Scene::AbsorptionModel::Conserving)
    init_absorption(p);
  if (!p.contact)
    return;
  const CouplingLimits lim = coupling_limits(scene_, double(p.dem.k), knit_->min_free_mass());
  knit_->set_substep_limit(lim.knit_substep);
  coupling_fluid_limit_ = lim.fluid_step;
}

template <typename T>
void SimulationT<T>::build_pipeline() {
  const bool contact = coupling_on_ && scene_.has(Module::Contact);
  const bool capillary = coupling_on_ && scene_.has(Module::Capillary);
  const char* coupling_module = capillary ? "capillary" : "contact";
  if (capillary && scene_.capillary.model == Scene::AbsorptionModel::Conserving) {
    pipeline_.add(
        "capillary.absorb", "capillary",
        "fluid particles touching an unsaturated knit point join its absorbed mass "
        "(mass and momentum kept; the particles are removed)",
        [this] {
          const auto split = absorption_split();
          const auto got = absorption_->absorb(ex_, knit_->set(), *fluid_, fluid_grid_->view(),
                                               *coupling_, split ? &*split : nullptr);
          if (absorption_ranks_ ? absorption_ranks_->settle(ex_, *fluid_, got) : got.removed > 0)
            sort_fluid();
        });
    pipeline_.add("capillary.diffuse", "capillary",
                  "absorbed fluid moves between neighbouring knit points (Darcy: capillary "
                  "suction and gravity)",
                  [this] {
                    const auto split = absorption_split();
                    absorption_->diffuse(ex_, knit_->set(), dt_, split ? &*split : nullptr);
                  });
    pipeline_.add("capillary.emit", "capillary",
                  "oversaturated knit points emit drops (fluid particles)", [this] {
                    const auto split = absorption_split();
                    if (absorption_->emit(ex_, knit_->set(), *fluid_, next_fluid_id_,
                                          split ? &*split : nullptr)) {
                      if (absorption_ranks_)
                        absorption_ranks_->appended(*fluid_);
                      sort_fluid();
                    }
                  });
  }
  if (coupling_on_)
    pipeline_.add("coupling.begin", coupling_module,
                  capillary ? "knit saturation (Eq. 9), Leverett J (Eq. 11), capillary pressure "
                              "(Eq. 10) from the fluid around each knit point; fluid impulses "
                              "cleared"
                            : "knit grid for the contact; fluid impulses cleared",
                  [this] { begin_coupling(); });
  if (knit_on_)
    pipeline_.add(
        "knit.step", "knit",
        std::to_string(scene_.knit.substeps) +
            " velocity Verlet substep(s): springs, gravity, contact with solids" +
            (scene_.knit.self_collision ? ", self-collision (DEM on a grid)" : "") +
            (contact ? ", fluid contact (DEM, Eq. 7, 8)" : "") +
            (capillary ? ", capillary force (Eq. 12) and the absorbed fluid's weight" : ""),
        [this] {
          const T keep = damping_keep(dt_ / scene_.knit.substeps);
          std::function<void(double)> move;
          if (moving_)
            move = [this](double t) { update_shapes(t); };
          std::function<void(T)> couple;
          if (coupling_on_)
            couple = [this](T weight) {
              coupling_->add_forces(ex_, knit_->set(), fluid_side(), weight);
            };
          if (knit_halo_ && !coupling_on_) { // else coupling.begin did
            if (!fluid_on_)                  // else the fluid's sort checks the balance
              ranks_->balance(steps_, nullptr, nullptr, &knit_->set().x, knit_->owned());
            knit_halo_->begin(knit_->expected_motion(dt_));
          }
          {
            const LocalWork work(ranks_ ? &*ranks_ : nullptr, Phase::Knit);
            knit_->advance(time_, dt_, keep, move, shapes_.data(), shapes_.size(), couple);
          }
          if (moving_)
            update_shapes(time_); // the fluid stages move the solids themselves
        });
  if (coupling_on_)
    pipeline_.add("coupling.impulse", coupling_module,
                  "the fluid takes the opposite of the knit's coupling impulse (two-way)",
                  [this] { coupling_->apply_impulses(ex_, fluid_->view()); });
  // With solids at rest the guard runs in the same pass as the drift (one read of x and v).
  const bool guard_fused = fluid_on_ && !solids_.empty() && !moving_;
  if (guard_fused)
    pipeline_.add("integrate.kick_drift", "fluid",
                  "velocity Verlet: half kick, drift; put back particles crossing into a solid "
                  "(counted)",
                  [this] {
                    drop_coupled_ghosts();
                    auto f = fluid_->view();
                    kick_drift_contact(ex_, f.x, f.v, f.a, f.n, static_cast<T>(dt_),
                                       damping_keep(dt_), false, Prescribed<T>{}, shapes_.data(),
                                       shapes_.size(), static_cast<T>(margin_), T(0),
                                       guard_count_.data(), "integrate.kick_drift", planned_dt(),
                                       kept_ghosts_flags());
                    after_drift();
                    settle_step();
                  });
  else if (fluid_on_)
    pipeline_.add("integrate.kick_drift", "fluid", "velocity Verlet: half kick, drift", [this] {
      drop_coupled_ghosts();
      auto f = fluid_->view();
      kick_drift(ex_, f.x, f.v, f.a, f.n, static_cast<T>(dt_), damping_keep(dt_),
                 "integrate.kick_drift", {}, planned_dt());
      after_drift();
      settle_step();
    });
  if (boundary_on_ && moving_) {
    pipeline_.add("boundary.move", "boundary", "translate moving obstacles", [this] {
      update_shapes(time_ + dt_);
      move_boundary(ex_, boundary_->view(), shapes_.data());
      if (ranks_) // the owners and the ghosts follow the solids
        ranks_->boundary_moved(*boundary_);
    });
    pipeline_.add("grid.boundary", "boundary", "sort boundary particles by cell",
                  [this] { sort_boundary(); });
  }
  if (fluid_on_ && !solids_.empty() && !guard_fused)
    pipeline_.add("boundary.guard", "boundary",
                  "put back particles crossing into a solid (counted)", [this] {
                    auto f = fluid_->view();
                    enforce_rigid_shapes(ex_, f.x, f.v, f.n, shapes_.data(), shapes_.size(),
                                         static_cast<T>(margin_), T(0), nullptr,
                                         guard_count_.data(), "boundary.guard");
                  });
  const auto& walls = scene_.domain.walls;
  const bool open = !std::all_of(walls.begin(), walls.end(), [](bool w) { return w; });
  using Lists = Scene::Solver::NeighbourLists;
  const Lists lists = scene_.solver.neighbour_list;
  // Fluid that left the domain through an open side is removed in the fluid's sort (grid.fluid,
  // counted). With "verlet" lists that is the next sort: a removal renumbers the fluid, so
  // removing at once rebuilt the lists at every step something left (the column's whole run:
  // ~13,000 of its 18,863 builds). Until then it is at most the skin outside (its displacement
  // since the last sort, when it was inside, stays within s).
  if (fluid_on_) {
    if (lists == Lists::Verlet)
      pipeline_.add("grid.fluid", "fluid",
                    open ? "when the lists might miss a pair: remove fluid that left the domain "
                           "(counted), sort fluid by cell, cell ranges, neighbour lists with a skin"
                         : "sort fluid by cell, cell ranges, neighbour lists with a skin, when "
                           "the lists might miss a pair",
                    [this, open] {
                      // The continuity predictor reads no neighbours: the GPU runs it while the
                      // host waits for the lists' reading (it runs again after a sort).
                      // On N ranks it runs after the sort: the ghosts received there would lack
                      // its gather copies.
                      std::function<void()> meanwhile;
                      if (continuity() && !ranks_)
                        meanwhile = [this] {
                          fluid_density(static_cast<T>(dt_));
                          density_done_ = true;
                        };
                      // Moving solids are sorted every step: their list entries would not last.
                      // On N ranks all take the same answer (SphLists::combine_readings).
                      if (fluid_list_->stale_after(ex_, *fluid_,
                                                   static_cast<T>(fluid_step_motion()), moving_,
                                                   meanwhile)) {
                        // Removing what left the domain in the same sort; the forces pass
                        // writes a before anything reads it; the predictor's copies, when it
                        // ran, are carried (not run again).
                        sort_fluid(open, {false, density_done_});
                      }
                    });
    else
      pipeline_.add("grid.fluid", "fluid",
                    std::string(open ? "remove fluid that left the domain (counted), " : "") +
                        (lists == Lists::On ? "sort fluid by cell, cell ranges, neighbour lists"
                                            : "sort fluid by cell, cell ranges"),
                    [this, open] { sort_fluid(open, {false}); }); // a: the forces pass follows
    pipeline_.add("sph.density", "fluid",
                  continuity() ? "pressure (EOS) of the density predicted for the step's end "
                                 "from the last two rates (continuity)"
                               : "density (Eq. 2) and pressure (EOS)",
                  [this] {
                    if (!density_done_)
                      fluid_density(static_cast<T>(dt_));
                    density_done_ = false;
                  });
    if (boundary_on_)
      pipeline_.add("boundary.pressure", "boundary", "wall pressure from the fluid (Adami 2012)",
                    [this] { extrapolate_boundary_pressure(); });
    pipeline_.add("sph.forces", "fluid",
                  continuity() ? "pressure (Eq. 3), viscosity (Eq. 4), gravity; density rate "
                                 "(continuity, delta-SPH diffusion) and the density's step"
                               : "pressure (Eq. 3), viscosity (Eq. 4), gravity",
                  [this] { fluid_forces(static_cast<T>(dt_)); });
    if (knit_on_) // the knit's coupling changes the fluid's velocities before the next dt
      pipeline_.add("integrate.kick", "fluid", "velocity Verlet: half kick", [this] {
        auto f = fluid_->view();
        kick(ex_, f.v, f.a, f.n, static_cast<T>(dt_), damping_keep(dt_), "integrate.kick");
        if (ranks_ && coupling_on_) // the ghosts the next coupling reads, their owners' motion
          ranks_->refresh_motion(*fluid_);
      });
    else
      pipeline_.add("integrate.kick", "fluid",
                    "velocity Verlet: half kick, and the bounds on speed and acceleration the next "
                    "step's size takes",
                    [this] {
                      auto f = fluid_->view();
                      kick_bounds(ex_, f.v, f.a, f.n, static_cast<T>(dt_), damping_keep(dt_),
                                  bounds_.data() + 1, "integrate.kick");
                      fluid_bounds_ready_ = true;
                    });
  }
}

template <typename T>
void SimulationT<T>::update_shapes(double t) {
  for (auto& s : solids_.table())
    s.offset = {static_cast<T>(s.velocity.x * t), static_cast<T>(s.velocity.y * t),
                static_cast<T>(s.velocity.z * t)};
  shapes_.assign(solids_.table());
}

template <typename T>
void SimulationT<T>::sort_fluid(bool remove_outflow, typename FluidSet<T>::Carry carry) {
  ++fluid_sorts_;
  if (ranks_) {
    // Ghosts kept since the last sort ("verlet" lists) go: the sort chooses them anew.
    ranks_->drop_ghosts(ex_, *fluid_);
    // Every [parallel] check_every steps the measured imbalance may share the blocks out anew.
    if (ranks_
            ->balance(steps_, &*fluid_, boundary_on_ ? &*boundary_ : nullptr,
                      knit_halo_ ? &knit_->set().x : nullptr, knit_halo_ ? knit_->owned() : 0)
            .repartitioned &&
        boundary_on_)
      sort_boundary();
    // Migration and the ghosts first, then the same sort over owned and ghost particles.
    const auto& d = scene_.domain;
    std::array<bool, 6> walls = d.walls;
    if (!remove_outflow)
      walls.fill(true);
    const auto gone =
        ranks_->rebuild(*fluid_, vec_cast<T>(d.min), vec_cast<T>(d.max), walls, carry.acceleration);
    outflow_particles_ += gone.particles;
    outflow_mass_ += gone.mass;
    fluid_grid_->build(ex_, fluid_->x.data(), fluid_->size(), fluid_->id.data());
    fluid_->reorder(ex_, fluid_grid_->permutation(), carry);
    ranks_->fluid_sorted(fluid_grid_->permutation(), fluid_->size());
  } else if (remove_outflow) {
    const auto& d = scene_.domain;
    outflow_particles_ +=
        sort_removing_outside(ex_, *fluid_grid_, *fluid_, vec_cast<T>(d.min), vec_cast<T>(d.max),
                              sorted_outflow_mass_.data(), carry);
  } else {
    fluid_grid_->build(ex_, fluid_->x.data(), fluid_->size(), fluid_->id.data());
    fluid_->reorder(ex_, fluid_grid_->permutation(), carry);
  }
  if (boundary_on_) // for boundary.pressure, which walks this grid until the next sort
    fluid_grid_->occupied_around(ex_, fluid_near_);
  if (fluid_list_)
    fluid_list_->build(ex_, *fluid_, fluid_grid_->view(), boundary_neighbours(), static_cast<T>(h_),
                       fluid_near_.data());
}

template <typename T>
double SimulationT<T>::fluid_step_motion() const {
  // The two-way coupling changes fluid velocities after the bounds were read: unknown.
  if (coupling_on_)
    return std::numeric_limits<double>::infinity();
  // Velocity Verlet moves a particle by dt (v + a dt / 2) with v and a at the step's start
  // (damping only slows it); the guard puts a particle that crossed into a solid back on its
  // surface, no farther from where it started than twice that. Plus rounding of x + dx.
  const double vmax = std::sqrt(static_cast<double>(fluid_bounds_.v2));
  const double amax = std::sqrt(static_cast<double>(fluid_bounds_.a2));
  const double drift = (vmax + 0.5 * amax * dt_) * dt_;
  const auto& d = scene_.domain;
  const double extent = std::max({std::abs(d.min.x), std::abs(d.min.y), std::abs(d.min.z),
                                  std::abs(d.max.x), std::abs(d.max.y), std::abs(d.max.z)});
  const double rounding = 4 * double(std::numeric_limits<T>::epsilon()) * (extent + h_);
  return (solids_.empty() ? 1.0 : 2.0) * drift * (1 + 1e-6) + rounding;
}

template <typename T>
void SimulationT<T>::sort_boundary() {
  boundary_grid_->build(ex_, boundary_->x.data(), boundary_->size());
  boundary_->reorder(ex_, boundary_grid_->permutation());
  if (ranks_)
    ranks_->boundary_sorted(boundary_grid_->permutation(), boundary_->size());
  boundary_grid_->occupied_around(ex_, boundary_near_);
  if (fluid_list_) // the walls' lists follow the boundary's order: built again with the fluid's
    fluid_list_->forget_walls();
}

template <typename T>
BoundaryNeighbours<T> SimulationT<T>::boundary_neighbours() {
  if (!boundary_on_ || boundary_->size() == 0)
    return {};
  return {boundary_->x.data(),
          boundary_->volume.data(),
          boundary_->xv.data(),
          boundary_->vp.data(),
          boundary_->inv_rho.data(),
          sph_.no_slip,
          boundary_grid_->view(),
          boundary_->size(),
          boundary_near_.data(),
          continuity() ? boundary_->obstacle.data() : nullptr,
          continuity() && moving_ ? shapes_.data() : nullptr};
}

template <typename T>
void SimulationT<T>::fluid_density(T dt) {
  if (continuity()) {
    const LocalWork work(ranks_ ? &*ranks_ : nullptr);
    sph_density_predict(ex_, sph_, fluid_->view(), dt);
    return;
  }
  if (!ranks_) {
    sph_density(ex_, sph_, fluid_->view(), fluid_grid_->view(), boundary_neighbours(),
                fluid_list_view());
    return;
  }
  {
    const LocalWork work(&*ranks_);
    sph_pack(ex_, fluid_->view());
  }
  // An outer ghost lacks neighbours past the halo: its owner's density replaces it.
  ranks_->refresh_density(*fluid_, [&](const exec::Rows& rows) {
    const LocalWork work(&*ranks_);
    sph_density_rows(ex_, sph_, fluid_->view(), fluid_grid_->view(), boundary_neighbours(),
                     fluid_list_view(), rows);
  });
}

template <typename T>
void SimulationT<T>::fluid_forces(T dt) {
  auto pass = [&](const exec::Rows* rows) {
    const LocalWork work(ranks_ ? &*ranks_ : nullptr);
    sph_forces(ex_, sph_, fluid_->view(), fluid_grid_->view(), boundary_neighbours(),
               fluid_list_view(), dt, rows);
  };
  if (!ranks_) {
    pass(nullptr);
    return;
  }
  // With the knit coupled the ghosts stay until the next drift (the coupling reads the fluid
  // around the knit), their motion refreshed after the kick: every row is computed.
  if (coupling_on_) {
    pass(nullptr);
    return;
  }
  const auto on_rows = [&](const exec::Rows& rows) { pass(&rows); };
  // Their work is done: between steps a rank holds only the fluid it owns; with "verlet" lists
  // the ghosts stay until the next sort, taking their owners' state now, so that the kick, the
  // drift and the next density pass give each the values its owner computes.
  if (ranks_->keeps_ghosts())
    ranks_->refresh_forces(*fluid_, continuity(), on_rows);
  else {
    ranks_->owned_pass(fluid_->size(), on_rows);
    ranks_->drop_ghosts(ex_, *fluid_);
  }
}

template <typename T>
void SimulationT<T>::compute_forces() {
  // dt 0: the density stays as it is (continuity), only its rate and the forces are evaluated.
  fluid_density(T(0));
  if (boundary_on_)
    extrapolate_boundary_pressure();
  fluid_forces(T(0));
}

template <typename T>
void SimulationT<T>::extrapolate_boundary_pressure() {
  auto pass = [&](const exec::Rows* rows) {
    const LocalWork work(ranks_ ? &*ranks_ : nullptr);
    if (boundary_->size() > 0)
      boundary_pressure(ex_, sph_, boundary_->view(), fluid_->view(), fluid_grid_->view(),
                        shapes_.data(), fluid_near_.data(),
                        fluid_list_ ? fluid_list_->walls() : ListView<T>{}, rows);
  };
  if (!ranks_) {
    pass(nullptr);
    return;
  }
  // Collective over the peers, so also where this rank holds no boundary.
  ranks_->refresh_boundary(*boundary_, [&](const exec::Rows& rows) { pass(&rows); });
}

template <typename T>
double SimulationT<T>::stable_dt() {
  const auto& s = scene_.solver;
  double dt = s.dt_max;
  if (!fluid_on_) {
    if (!knit_on_)
      return dt;
    if (!ranks_)
      return std::min(dt, knit_->stable_dt());
    knit_->motion_bounds_to(bounds_.data());
    auto kb = bounds_.to_host()[0];
    job_bounds(&kb, 1);
    return std::min(dt, knit_->stable_dt(kb));
  }
  auto f = fluid_->view();
  MotionBounds<T> mb;
  if (knit_on_) { // both sets' bounds in one read
    knit_->motion_bounds_to(bounds_.data());
    motion_bounds_to(ex_, f.v, f.a, f.n, bounds_.data() + 1, "integrate.dt");
    auto both = bounds_.to_host();
    if (ranks_)
      job_bounds(both.data(), 2);
    dt = std::min(dt, knit_->stable_dt(both[0]));
    mb = both[1];
  } else if (fluid_bounds_ready_) {
    mb = bounds_.to_host()[1];
  } else {
    mb = motion_bounds(ex_, f.v, f.a, f.n, "integrate.dt");
  }
  if (ranks_ && !knit_on_) { // one dt for the job: the largest speed and acceleration of all ranks
    if (!(std::isfinite(double(mb.v2)) && std::isfinite(double(mb.a2))))
      report_instability("a fluid velocity or acceleration is not finite");
    job_bounds(&mb, 1);
  }
  fluid_bounds_ = mb;
  if (!(std::isfinite(double(mb.v2)) && std::isfinite(double(mb.a2))))
    report_instability("a fluid velocity or acceleration is not finite");
  return std::min(dt, fluid_stable_dt(fluid_step_rule(), double(mb.v2), double(mb.a2)));
}

template <typename T>
void SimulationT<T>::job_bounds(MotionBounds<T>* mb, int n) const {
  std::vector<double> b(2 * n);
  for (int k = 0; k < n; ++k) {
    b[2 * k] = double(mb[k].v2);
    b[2 * k + 1] = double(mb[k].a2);
  }
  for (double& v : b)
    v = std::isnan(v) ? std::numeric_limits<double>::infinity() : v;
  MPI_Allreduce(MPI_IN_PLACE, b.data(), 2 * n, MPI_DOUBLE, MPI_MAX, ranks_->mpi().comm());
  for (int k = 0; k < n; ++k) {
    mb[k].v2 = static_cast<T>(b[2 * k]);
    mb[k].a2 = static_cast<T>(b[2 * k + 1]);
  }
}

template <typename T>
FluidStepRule SimulationT<T>::fluid_step_rule() const {
  const auto& s = scene_.solver;
  FluidStepRule r;
  r.limit = std::min(s.dt_max, coupling_fluid_limit_);
  if (scene_.fluid.viscosity > 0)
    r.limit = std::min(r.limit, s.viscous_factor * h_ * h_ * scene_.fluid.rest_density /
                                    scene_.fluid.viscosity);
  r.cfl = s.cfl;
  r.h = h_;
  r.sound = scene_.fluid.speed_of_sound;
  r.force_factor = s.force_factor;
  r.dt_min = s.dt_min;
  return r;
}

template <typename T>
bool SimulationT<T>::plans_step_on_device() const {
  // The drift must be the step's first stage (no knit or coupling stages before it, which take
  // dt on the host), its bounds on the device already, and no damping (keep depends on dt).
  const auto& s = scene_.solver;
  return fluid_on_ && !knit_on_ && !coupling_on_ && fluid_bounds_ready_ && !ranks_ &&
         !(s.damping > 0 && time_ < s.damping_until);
}

template <typename T>
void SimulationT<T>::settle_step() {
  if (!step_pending_)
    return;
  const StepPlan<T> p = plan_read_->wait()[0];
  step_pending_ = false;
  fluid_bounds_ = p.bounds;
  // The plan's dt is 0 in both cases below: the drift queued with it moved nothing.
  if (!p.finite)
    report_instability("a fluid velocity or acceleration is not finite");
  if (p.stable_dt < scene_.solver.dt_min)
    report_instability("the stable time step " + std::to_string(p.stable_dt) +
                       " s fell below dt_min " + std::to_string(scene_.solver.dt_min) + " s");
  dt_ = p.dt;
  step_lands_ = p.lands != 0;
}

template <typename T>
double SimulationT<T>::step(double t_limit) {
  // Land exactly on t_limit (output times), without leaving a sliver of a step before it.
  const double remaining = t_limit - time_;
  if (plans_step_on_device()) {
    if (!plan_read_)
      plan_read_.emplace(ex_.backend, 1, "integrate.dt");
    plan_fluid_step(ex_, fluid_step_rule(), bounds_.data() + 1, remaining, plan_.data());
    plan_read_->start(plan_.data());
    step_pending_ = true;
    dt_ = std::numeric_limits<double>::quiet_NaN(); // known once the drift is queued
  } else {
    const double dt = stable_dt();
    if (dt < scene_.solver.dt_min)
      report_instability("the stable time step " + std::to_string(dt) + " s fell below dt_min " +
                         std::to_string(scene_.solver.dt_min) + " s");
    bool lands = false;
    dt_ = landed_dt(dt, remaining, lands);
    step_lands_ = lands;
  }
  fluid_bounds_ready_ = false; // the stages change v and a; the step's last kick writes them
  pipeline_.run(profiling_ ? std::function<void()>([this] { exec::synchronize(ex_.backend); })
                           : std::function<void()>());
  settle_step(); // the drift stage settles it; a pipeline without one would still
  time_ = step_lands_ ? t_limit : time_ + dt_;
  ++steps_;
  return dt_;
}

template <typename T>
void SimulationT<T>::report_instability(const std::string& why) {
  std::ostringstream msg;
  msg << "instability at step " << steps_ << ", t = " << time_ << " s: " << why;
  if (fluid_on_) {
    const auto v = fluid_->v.to_host();
    const auto a = fluid_->a.to_host();
    const auto x = fluid_->x.to_host();
    const auto id = fluid_->id.to_host();
    std::size_t worst = 0;
    double worst_v = -1;
    for (std::size_t i = 0; i < v.size(); ++i) {
      const double s = std::sqrt(double(norm2(v[i]))) + std::sqrt(double(norm2(a[i])));
      if (!std::isfinite(s)) {
        worst = i;
        break;
      }
      if (s > worst_v) {
        worst_v = s;
        worst = i;
      }
    }
    if (!v.empty())
      msg << "; worst fluid particle id " << id[worst] << " at (" << x[worst].x << ", "
          << x[worst].y << ", " << x[worst].z
          << ") with |v| = " << std::sqrt(double(norm2(v[worst])))
          << " m/s, |a| = " << std::sqrt(double(norm2(a[worst]))) << " m/s^2";
  }
  throw InstabilityError(msg.str());
}

template <typename T>
io::Frame SimulationT<T>::frame() const {
  io::Frame fr;
  fr.time = time_;
  fr.step = steps_;
  fr.scene_text = scene_.text;
  fr.precision = std::string(to_string(scene_.precision));
  // On N ranks the counters are the job's (each rank counts its own particles).
  const auto job = [this](double v) { return ranks_ ? ranks_->mpi().sum(v) : v; };
  fr.scalars.push_back({"guard_corrections", job(static_cast<double>(guard_corrections()))});
  fr.scalars.push_back({"outflow_particles", job(static_cast<double>(outflow_particles_))});
  fr.scalars.push_back({"outflow_mass", job(outflow_mass())});
  fr.scalars.push_back({"next_fluid_id", static_cast<double>(next_fluid_id_)});
  if (fluid_on_) {
    io::Phase p{"fluid", {}};
    p.fields.push_back(io::Field::from("position", flatten(fluid_->x.to_host()), 3));
    p.fields.push_back(io::Field::from("velocity", flatten(fluid_->v.to_host()), 3));
    p.fields.push_back(io::Field::from("acceleration", flatten(fluid_->a.to_host()), 3));
    p.fields.push_back(io::Field::from("mass", fluid_->m.to_host(), 1));
    p.fields.push_back(io::Field::from("density", fluid_->rho.to_host(), 1));
    p.fields.push_back(io::Field::from("pressure", fluid_->p.to_host(), 1));
    // Under continuity the density's rates are state the next step needs, like a.
    if (continuity()) {
      p.fields.push_back(io::Field::from("density_rate", fluid_->drho.to_host(), 1));
      p.fields.push_back(io::Field::from("density_rate_previous", fluid_->drho_prev.to_host(), 1));
    }
    p.fields.push_back(io::Field::from("id", fluid_->id.to_host(), 1));
    if (ranks_) { // which rank owns each particle (ParaView colours by it); ghosts not written
      keep_rows(p, fluid_owned_rows());
      p.fields.push_back(io::Field::from(
          "rank", std::vector<std::uint32_t>(p.fields[0].count, std::uint32_t(ranks_->rank())), 1));
    }
    // "verlet" lists: the positions they were built for and the rule's bounds since, so that a
    // restart lists and sorts the fluid when this run does (restore_fluid_grid). One rank only:
    // on N ranks each rank lists its ghosts too and builds at steps of its own (the local rule),
    // and a restart partitions anew and lists at its first step (restore).
    if (fluid_list_ && skin_ > 0 && !ranks_) {
      const auto st = fluid_list_->state();
      if (!st.x0.empty()) {
        p.fields.push_back(io::Field::from("listed_position", flatten(st.x0), 3));
        fr.scalars.push_back({"list_bound", static_cast<double>(st.bound)});
        fr.scalars.push_back({"list_pair_bound", static_cast<double>(st.pair)});
      }
    }
    fr.phases.push_back(std::move(p));
  }
  if (boundary_on_) {
    io::Phase p{"boundary", {}};
    p.fields.push_back(io::Field::from("position", flatten(boundary_->x.to_host()), 3));
    p.fields.push_back(io::Field::from("rest_position", flatten(boundary_->x0.to_host()), 3));
    p.fields.push_back(io::Field::from("volume", boundary_->volume.to_host(), 1));
    p.fields.push_back(io::Field::from("pressure", boundary_->p.to_host(), 1));
    p.fields.push_back(io::Field::from("obstacle", boundary_->obstacle.to_host(), 1));
    p.fields.push_back(io::Field::from("id", boundary_->id.to_host(), 1));
    if (ranks_) { // the ghosts are their owners' to write
      keep_rows(p, ranks_->boundary_owned());
      p.fields.push_back(io::Field::from(
          "rank", std::vector<std::uint32_t>(p.fields[0].count, std::uint32_t(ranks_->rank())), 1));
    }
    fr.phases.push_back(std::move(p));
  }
  if (knit_on_) {
    io::Phase kp = knit_->phase();
    std::vector<double> wet; // the knit's saturation, for the yarns
    const bool wets = coupling_ && scene_.has(Module::Capillary);
    if (wets) {
      std::vector<T> sat, held;
      if (absorption_) {
        held = absorption_->absorbed().to_host();
        const auto cap = absorption_->capacity().to_host();
        sat.resize(held.size());
        for (std::size_t i = 0; i < held.size(); ++i)
          sat[i] = held[i] / cap[i];
      } else {
        sat = coupling_->saturation().to_host();
        held = coupling_->fluid_mass().to_host();
      }
      sat.resize(knit_->owned()); // on N ranks the ghosts' follow
      held.resize(knit_->owned());
      wet.assign(sat.begin(), sat.end());
      kp.fields.push_back(io::Field::from("saturation", sat, 1));
      kp.fields.push_back(io::Field::from("fluid_mass", held, 1));
    }
    // The knit's grids kept over steps (self-collision, coupling): a restart sorts them when
    // this run does, so their sums keep this run's order.
    if (knit_halo_ && knit_->self_collision())
      put_watch<T>(fr, kp, "self_contact", knit_halo_->self_contact_state(), true);
    else if (const auto st = knit_->self_contact_state())
      put_watch<T>(fr, kp, "self_contact", *st);
    if (coupling_)
      put_watch<T>(fr, kp, "coupling",
                   knit_halo_ ? knit_halo_->coupling_state() : coupling_->state(),
                   knit_halo_.has_value());
    if (ranks_)
      kp.fields.push_back(io::Field::from(
          "rank", std::vector<std::uint32_t>(knit_->owned(), std::uint32_t(ranks_->rank())), 1));
    fr.phases.push_back(std::move(kp));
    if (scene_.knit.yarn_samples > 0) {
      if (knit_halo_) { // the yarns run through points of every rank: rank 0 writes them all
        const auto all = knit_halo_->positions_on_root();
        const auto wet_all = wets ? knit_halo_->values_on_root(wet) : wet; // collective
        fr.phases.push_back(knit_->yarn_phase(wets ? &wet_all : nullptr, &all));
      } else {
        fr.phases.push_back(knit_->yarn_phase(wet.empty() ? nullptr : &wet));
      }
    }
  }
  return fr;
}

template <typename T>
void SimulationT<T>::restore(const io::Frame& fr) {
  fluid_bounds_ready_ = false;
  // On N ranks every rank reads the whole frame, whatever rank count wrote it, and keeps what
  // it owns (below); the job's counters are taken once, on rank 0.
  const bool counters = !ranks_ || ranks_->rank() == 0;
  if (fr.precision != to_string(scene_.precision))
    throw Error("restart: the snapshot holds " + fr.precision + " data but the scene asks for " +
                std::string(to_string(scene_.precision)));
  time_ = fr.time;
  steps_ = fr.step;
  for (const auto& [k, v] : fr.scalars)
    if (k == "guard_corrections")
      guard_count_.assign(std::vector<std::uint64_t>{counters ? static_cast<std::uint64_t>(v) : 0});
    else if (k == "outflow_particles")
      outflow_particles_ = counters ? static_cast<std::uint64_t>(v) : 0;
    else if (k == "outflow_mass") {
      outflow_mass_ = counters ? v : 0.0;
      sorted_outflow_mass_.assign(std::vector<double>{0.0});
    } else if (k == "next_fluid_id")
      next_fluid_id_ = static_cast<std::uint64_t>(v);
  update_shapes(time_);
  if (fluid_on_) {
    const io::Phase* p = fr.find("fluid");
    if (!p)
      throw Error("restart: the snapshot has no fluid phase but the scene has fluid");
    const auto x = unflatten(require(*p, "position").as<T>());
    fluid_->resize(x.size());
    fluid_->x.assign(x);
    fluid_->v.assign(unflatten(require(*p, "velocity").as<T>()));
    fluid_->a.assign(unflatten(require(*p, "acceleration").as<T>()));
    fluid_->m.assign(require(*p, "mass").as<T>());
    fluid_->rho.assign(require(*p, "density").as<T>());
    fluid_->p.assign(require(*p, "pressure").as<T>());
    if (continuity()) {
      const io::Field* r = p->find("density_rate");
      if (!r)
        throw Error("restart: the snapshot's fluid has no density_rate but the scene integrates "
                    "the density (solver.density = \"continuity\"); it was written with "
                    "\"summation\"");
      fluid_->drho.assign(r->as<T>());
      fluid_->drho_prev.assign(require(*p, "density_rate_previous").as<T>());
    } else {
      fluid_->drho.assign(std::vector<T>(x.size(), T(0)));
      fluid_->drho_prev.assign(std::vector<T>(x.size(), T(0)));
    }
    fluid_->id.assign(require(*p, "id").as<std::uint64_t>());
  }
  if (boundary_on_) {
    const io::Phase* p = fr.find("boundary");
    if (!p)
      throw Error("restart: the snapshot has no boundary phase but the scene has one");
    const auto x = unflatten(require(*p, "position").as<T>());
    boundary_->resize(x.size());
    boundary_->x.assign(x);
    boundary_->x0.assign(unflatten(require(*p, "rest_position").as<T>()));
    boundary_->obstacle.assign(require(*p, "obstacle").as<std::uint32_t>());
    boundary_->volume.assign(require(*p, "volume").as<T>());
    boundary_->id.assign(require(*p, "id").as<std::uint64_t>());
    // Same order as when written, so the grid comes out identical.
    if (!ranks_)
      sort_boundary();
  }
  std::optional<io::Phase> knit_phase;
  if (knit_on_) {
    const io::Phase* p = fr.find("knit");
    if (!p)
      throw Error("restart: the snapshot has no knit phase but the scene has knit");
    knit_phase = *p;
    rows_by_id(*knit_phase); // in mesh order, whatever rank count wrote it
    knit_->restore(*knit_phase);
    if (absorption_) { // the whole knit's, before N ranks share the points out again
      const io::Field* a = knit_phase->find("fluid_mass");
      if (!a)
        throw Error("restart: the snapshot's knit has no fluid_mass but the scene absorbs fluid "
                    "(capillary.model = \"conserving\")");
      absorption_->restore(ex_, knit_->set(), a->as<T>());
    }
  }
  if (ranks_) {
    // The blocks are partitioned anew from the frame's particles (the results do not depend on
    // the partition), each rank keeps its share, and the next step's sort rebuilds the rest.
    ranks_->distribute(fluid_on_ ? &*fluid_ : nullptr, boundary_on_ ? &*boundary_ : nullptr,
                       all_knit_positions(), steps_);
    if (fluid_list_) // "verlet" lists: built at the next step for the positions then
      fluid_list_->forget();
    if (boundary_on_)
      sort_boundary();
    if (knit_halo_) {
      // The grids' reference positions travel with the points; without them (an older
      // snapshot) the positions now.
      const auto watch = [&](bool on, const char* name) {
        const auto st = on ? get_watch<T>(fr, *knit_phase, name) : std::nullopt;
        return st ? *st : typename SkinWatch<T>::State{{}, T(0), T(0)};
      };
      knit_halo_->distribute(watch(knit_->self_collision(), "self_contact"),
                             watch(coupling_.has_value(), "coupling"));
    }
    if (coupling_on_) {
      // The coupling reads the fluid around each knit point before the next drift: the ghosts
      // and the grid now, for the same positions as the run that wrote the frame sorted them.
      sort_fluid(false, {true});
      ranks_->refresh_motion(*fluid_);
      update_saturation();
    }
    return;
  }
  if (knit_on_) {
    const io::Phase* p = &*knit_phase;
    // Without their state (an older snapshot) the grids stay as built for the scene's start:
    // correct (their watches measure from there), but not sorted when the run it continues
    // sorted them, so rounding may differ.
    if (knit_->self_collision())
      if (const auto st = get_watch<T>(fr, *p, "self_contact"))
        knit_->restore_self_contact(*st);
    if (coupling_)
      if (const auto st = get_watch<T>(fr, *p, "coupling"))
        coupling_->restore(ex_, knit_->set(), *st);
  }
  if (fluid_on_)
    restore_fluid_grid(fr);
  if (coupling_on_)
    update_saturation();
}

template <typename T>
void SimulationT<T>::restore_fluid_grid(const io::Frame& fr) {
  // The stages before a step's sort walk the fluid's grid (absorption, the coupling), and
  // "verlet" lists keep it over steps: the grid must be the one the uninterrupted run holds,
  // not the scene's first. The snapshot's fluid is in the order of that run's last sort, for
  // the positions it had then: the positions now (walk, or "on": sorted every step after the
  // drift), or those the lists were built for ("verlet", written with them). The sort is
  // stable, so sorting for the same positions again keeps the order (the identity permutation;
  // any other is applied to the fields the sort does not carry) and rebuilds the grid, the
  // flags of the cells near fluid and the lists bit for bit. The rule's bounds since that build
  // are restored too, so the lists are built again at the step the run built them.
  const std::vector<Vec3<T>> x = fluid_->x.to_host();
  const std::vector<Vec3<T>> a = fluid_->a.to_host();
  const std::vector<T> pressure = fluid_->p.to_host();
  std::optional<typename SphLists<T>::State> listed;
  if (fluid_list_ && skin_ > 0) {
    const io::Field* x0 = fr.find("fluid")->find("listed_position");
    const double* bound = find_scalar(fr, "list_bound");
    const double* pair = find_scalar(fr, "list_pair_bound");
    if (x0 && bound && pair) {
      listed = {unflatten(x0->as<T>()), static_cast<T>(*bound), static_cast<T>(*pair)};
      if (listed->x0.size() != x.size())
        throw Error("restart: the snapshot lists " + std::to_string(listed->x0.size()) +
                    " fluid particles but holds " + std::to_string(x.size()));
      fluid_->x.assign(listed->x0);
    }
    // Else (an older snapshot) the lists are built for the positions now: correct, but the
    // run it continues kept older lists, so rounding may differ.
  }
  sort_fluid(false, {false, false}); // a and p: put back below
  if (fluid_list_)
    fluid_list_->settle(ex_); // before anything rewrites the positions it listed
  const std::vector<std::uint32_t> perm = fluid_grid_->permutation().to_host();
  if (listed) {
    fluid_->x.assign(permuted(x, perm));
    fluid_list_->restore(*listed);
  }
  fluid_->a.assign(permuted(a, perm));
  fluid_->p.assign(permuted(pressure, perm));
}

template <typename T>
Diagnostics SimulationT<T>::diagnostics() const {
  Diagnostics d;
  d.guard_corrections = guard_corrections();
  d.fluid_sorts = fluid_sorts_;
  if (fluid_list_ && skin_ > 0) {
    const auto& e = fluid_list_->ends();
    d.list_ends_far = e.far;
    d.list_ends_sheared = e.sheared;
    d.list_skin = static_cast<double>(fluid_list_->skin());
  }
  if (boundary_on_)
    d.boundary = boundary_->size();
  if (knit_on_) {
    auto& k = const_cast<KnitSystem<T>&>(*knit_);
    KnitEnergy e;
    SelfContactStats sc;
    // The springs and contacts of owned points reach ghosts on N ranks.
    const_cast<SimulationT<T>&>(*this).with_knit_ghosts([&] { e = k.energy(&sc); });
    d.knit = k.owned();
    d.knit_kinetic_energy = e.kinetic;
    d.knit_elastic_energy = e.elastic;
    d.knit_potential_energy = e.potential;
    d.knit_contacts = k.collisions();
    d.knit_self_contacts = sc.contacts;
    d.knit_self_energy = sc.energy;
    d.knit_self_min_gap = sc.min_gap_ratio;
    if (coupling_) {
      auto& self = const_cast<SimulationT<T>&>(*this);
      const CouplingStats cs = self.coupling_->stats(ex_, self.knit_->set(), self.fluid_side());
      d.coupling_contacts = cs.contacts;
      d.coupling_energy = cs.energy;
      d.absorbed_mass = cs.absorbed_mass;
      d.max_saturation = cs.max_saturation;
      d.mean_saturation = cs.mean_saturation;
      d.wet_points = cs.wet_points;
      if (ranks_) { // the job's (each rank's over its own knit points)
        const comm::MpiContext& mpi = ranks_->mpi();
        const double n = double(k.owned()), all = double(mpi.sum(std::uint64_t(k.owned())));
        d.coupling_contacts = mpi.sum(std::uint64_t(d.coupling_contacts));
        d.coupling_energy = mpi.sum(d.coupling_energy);
        d.absorbed_mass = mpi.sum(d.absorbed_mass);
        d.max_saturation = mpi.max(d.max_saturation);
        d.mean_saturation = all > 0 ? mpi.sum(d.mean_saturation * n) / all : 0.0;
        d.wet_points = mpi.sum(std::uint64_t(d.wet_points));
      }
      if (absorption_) {
        const AbsorptionStats& st = absorption_->stats();
        const auto a = absorption_->absorbed().to_host();
        d.absorbed_mass = 0;
        for (std::size_t i = 0; i < k.owned(); ++i) // on N ranks the ghosts are their owners'
          d.absorbed_mass += double(a[i]);
        d.absorbed_particles = st.absorbed_particles;
        d.emitted_particles = st.emitted_particles;
        d.diffused_mass = st.diffused_mass;
        if (ranks_) { // the job's (each rank's over its own points and particles)
          const comm::MpiContext& mpi = ranks_->mpi();
          d.absorbed_mass = mpi.sum(d.absorbed_mass);
          d.absorbed_particles = mpi.sum(std::uint64_t(d.absorbed_particles));
          d.emitted_particles = mpi.sum(std::uint64_t(d.emitted_particles));
          d.diffused_mass = mpi.sum(d.diffused_mass);
        }
      }
    }
    d.knit_min_rigid_distance = solids_.empty()
                                    ? std::numeric_limits<double>::infinity()
                                    : k.min_rigid_distance(shapes_.data(), shapes_.size());
    if (ranks_) { // the job's: each rank holds its own points between steps
      const comm::MpiContext& mpi = ranks_->mpi();
      d.knit = mpi.sum(std::uint64_t(d.knit));
      d.knit_kinetic_energy = mpi.sum(d.knit_kinetic_energy);
      d.knit_elastic_energy = mpi.sum(d.knit_elastic_energy);
      d.knit_potential_energy = mpi.sum(d.knit_potential_energy);
      d.knit_contacts = mpi.sum(std::uint64_t(d.knit_contacts));
      d.knit_self_contacts = mpi.sum(std::uint64_t(d.knit_self_contacts));
      d.knit_self_energy = mpi.sum(d.knit_self_energy);
      d.knit_self_min_gap = mpi.min(d.knit_self_min_gap);
      d.knit_min_rigid_distance = mpi.min(d.knit_min_rigid_distance);
      if (!fluid_on_) {
        d.imbalance = ranks_->last_imbalance();
        d.repartitions = ranks_->repartitions();
      }
    }
  }
  if (!fluid_on_)
    return d;
  d.outflow_particles = outflow_particles_;
  d.outflow_mass = outflow_mass();
  const auto v = fluid_->v.to_host();
  const auto m = fluid_->m.to_host();
  const auto rho = fluid_->rho.to_host();
  const auto own = fluid_owned_rows(); // on N ranks with the knit coupled, ghosts follow
  d.fluid = std::count(own.begin(), own.end(), 1);
  const double rho0 = scene_.fluid.rest_density;
  double sum_err = 0;
  for (std::size_t i = 0; i < v.size(); ++i) {
    if (!own[i])
      continue;
    const double v2 = norm2(vec_cast<double>(v[i]));
    d.kinetic_energy += 0.5 * m[i] * v2;
    d.fluid_mass += m[i];
    d.max_speed = std::max(d.max_speed, std::sqrt(v2));
    const double e = (rho[i] - rho0) / rho0;
    d.max_density_error = std::max(d.max_density_error, e);
    sum_err += e;
  }
  if (d.fluid)
    d.mean_density_error = sum_err / d.fluid;
  d.min_rigid_distance =
      solids_.empty() ? std::numeric_limits<double>::infinity()
                      : static_cast<double>(min_rigid_distance(
                            ex_, fluid_->x.data(), fluid_->size(), shapes_.data(), shapes_.size()));
  if (ranks_) { // the job's figures: each rank holds its owned fluid between steps
    const comm::MpiContext& mpi = ranks_->mpi();
    if (boundary_on_) {
      const auto& own = ranks_->boundary_owned();
      d.boundary = mpi.sum(std::uint64_t(std::count(own.begin(), own.end(), 1)));
    }
    const std::uint64_t local = d.fluid;
    d.fluid = mpi.sum(local);
    d.kinetic_energy = mpi.sum(d.kinetic_energy);
    d.fluid_mass = mpi.sum(d.fluid_mass);
    d.max_speed = mpi.max(d.max_speed);
    d.max_density_error = mpi.max(local == 0 ? -1e300 : d.max_density_error);
    d.mean_density_error = d.fluid ? mpi.sum(sum_err) / double(d.fluid) : 0.0;
    d.min_rigid_distance = mpi.min(d.min_rigid_distance);
    d.guard_corrections = mpi.sum(d.guard_corrections);
    d.outflow_particles = mpi.sum(d.outflow_particles);
    d.outflow_mass = mpi.sum(d.outflow_mass);
    d.imbalance = ranks_->last_imbalance();
    d.repartitions = ranks_->repartitions();
  }
  return d;
}

template <typename T>
std::size_t SimulationT<T>::memory_bytes() const {
  std::size_t b = shapes_.capacity_bytes() + solids_.bytes();
  if (fluid_)
    b += fluid_->bytes() + fluid_grid_->bytes() + (fluid_list_ ? fluid_list_->bytes() : 0);
  if (boundary_)
    b += boundary_->bytes() + boundary_grid_->bytes() + boundary_near_.capacity_bytes() +
         fluid_near_.capacity_bytes();
  if (knit_)
    b += knit_->bytes();
  return b;
}

namespace {

std::string describe_obstacle(const Obstacle& o) {
  std::string line = o.name + ": " + to_string(o.shape);
  if (o.shape != ObstacleShape::Mesh || !o.mesh)
    return line;
  const MeshObstacle& m = *o.mesh;
  char buf[256];
  std::snprintf(buf, sizeof buf,
                " %s, %zu triangles, volume %.4g m^3, distance sampled on %u x %u x %u nodes "
                "(cell %.3g m) in %.2f s",
                o.file.c_str(), m.solid.triangles.size(), m.solid.volume, m.sdf.dims[0],
                m.sdf.dims[1], m.sdf.dims[2], m.sdf.cell, m.build_seconds);
  return line + buf;
}

} // namespace

PlanReport Simulation::plan(const Scene& scene) {
  PlanReport r;
  const bool dbl = scene.precision == Precision::Double;
  std::unique_ptr<Simulation> shell;
  if (dbl)
    shell.reset(new SimulationT<double>(scene, exec::Backend::Cpu, true));
  else
    shell.reset(new SimulationT<float>(scene, exec::Backend::Cpu, true));
  for (const auto& s : shell->pipeline().stages())
    r.stages.push_back({s.name + " [" + s.module + "]", s.what});
  r.support_radius = scene.support_radius();
  for (const auto& o : scene.obstacles)
    r.obstacles.push_back(describe_obstacle(o));
  r.bytes_solids = dbl ? RigidShapes<double>(scene).bytes() : RigidShapes<float>(scene).bytes();
  const double h = r.support_radius;
  const int span = static_cast<int>(scene.solver.cell_span);
  const auto geo = NeighbourGrid<double>::cover(scene.domain.min, scene.domain.max, h / span, span);
  r.grid[0] = geo.nx;
  r.grid[1] = geo.ny;
  r.grid[2] = geo.nz;
  const std::size_t grid_bytes = std::size_t(geo.cells()) * 3 * sizeof(std::uint32_t);
  if (scene.has(Module::Fluid)) {
    r.fluid = sample_fluid(scene).size();
    r.bytes_fluid = r.fluid * (dbl ? FluidSet<double>::bytes_per_particle()
                                   : FluidSet<float>::bytes_per_particle());
    r.bytes_grid += grid_bytes;
  }
  if (scene.has(Module::Boundary)) {
    r.boundary = sample_boundaries(scene, scene.fluid.spacing, h).x.size();
    r.bytes_boundary = r.boundary * (dbl ? BoundarySet<double>::bytes_per_particle()
                                         : BoundarySet<float>::bytes_per_particle());
    r.bytes_grid += grid_bytes;
  }
  // Initial dt from the initial velocities and gravity (the first forces are not evaluated).
  const auto& s = scene.solver;
  double vmax = 0;
  for (const auto& b : scene.fluid.blocks)
    vmax = std::max(vmax, norm(b.velocity));
  r.initial_dt = s.dt_max;
  r.dt_limit = "dt_max";
  auto limit = [&](double dt, const char* why) {
    if (dt < r.initial_dt) {
      r.initial_dt = dt;
      r.dt_limit = why;
    }
  };
  if (scene.has(Module::Fluid)) {
    limit(s.cfl * h / (scene.fluid.speed_of_sound + vmax), "CFL (sound speed + velocity)");
    const double g = norm(scene.gravity);
    if (g > 0)
      limit(s.force_factor * std::sqrt(h / g), "force (gravity)");
    if (scene.fluid.viscosity > 0)
      limit(s.viscous_factor * h * h * scene.fluid.rest_density / scene.fluid.viscosity,
            "viscosity");
  }
  if (scene.has(Module::Knit)) {
    // Built in the scene's precision on the host (the CPU backend): plan never touches a device.
    auto count = [&](auto&& knit) {
      r.knit = knit.size();
      r.springs = knit.springs().springs();
      r.volume_cells = knit.volume_cells();
      if (const auto* sc = knit.self_contact_params())
        r.knit_self_radius = double(sc->radius);
      r.bytes_knit = knit.bytes();
      if (scene.has(Module::Contact) || scene.has(Module::Capillary)) {
        const auto p = coupling_params<double>(scene, knit.longest_spacing());
        r.coupling_reach = p.reach;
        r.coupling_stiffness = p.contact ? p.dem.k : 0;
        if (p.contact) {
          const CouplingLimits lim = coupling_limits(scene, p.dem.k, knit.min_free_mass());
          knit.set_substep_limit(lim.knit_substep);
          limit(lim.fluid_step, "fluid-knit contact stiffness (fluid side)");
        }
      }
      limit(knit.stable_dt(), "knit springs / contact stiffness / contact radius (all substeps)");
    };
    const exec::Exec host{exec::Backend::Cpu};
    if (dbl)
      count(KnitSystem<double>(scene, host));
    else
      count(KnitSystem<float>(scene, host));
  }
  return r;
}

std::unique_ptr<Simulation> Simulation::create(const Scene& scene, exec::Backend backend,
                                               const comm::MpiContext* mpi) {
  if (backend == exec::Backend::Cuda && !exec::cuda_available())
    throw Error(exec::cuda_compiled() ? "--device cuda: no CUDA device is visible"
                                      : "--device cuda: this knitflow was built without CUDA");
  if (scene.precision == Precision::Double)
    return std::make_unique<SimulationT<double>>(scene, backend, false, mpi);
  return std::make_unique<SimulationT<float>>(scene, backend, false, mpi);
}

} // namespace kf
