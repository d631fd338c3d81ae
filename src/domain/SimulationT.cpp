// SimulationT<T>: set-up (particles, knit, coupling, the split over ranks) and the pipeline's
// stages. The passes themselves are in SimulationFluid.cpp and SimulationStep.cpp.
#include "domain/SimulationT.hpp"

#include "domain/PoreNetwork.hpp"
#include "domain/SceneSampler.hpp"
#include "domain/SheetFaces.hpp"

#include <numeric>

namespace kf {

template <typename T>
SimulationT<T>::SimulationT(const Scene& scene, exec::Backend backend, Build build,
                            const comm::MpiContext* mpi)
    : scene_(scene), ex_{backend}, shift_(backend, 0, "sph.shift"),
      guard_count_(backend, 0, "boundary.guard_count"),
      sorted_outflow_mass_(backend, 0, "fluid.outflow"),
      sheet_count_(backend, 0, "sheet_guard.count"), boundary_near_(backend, 0, "boundary.near"),
      fluid_near_(backend, 0, "fluid.near"), bounds_(backend, 3, "integrate.dt"),
      plan_(backend, 1, "integrate.dt"), solids_(scene, backend),
      shapes_(backend, 0, "rigid.shapes") {
  guard_count_.assign(std::vector<std::uint64_t>{0});
  sorted_outflow_mass_.assign(std::vector<double>{0.0});
  fluid_on_ = scene.has(Module::Fluid);
  boundary_on_ = scene.has(Module::Boundary);
  knit_on_ = scene.has(Module::Knit);
  coupling_on_ =
      fluid_on_ && knit_on_ && (scene.has(Module::Contact) || scene.has(Module::Capillary));
  {
    using G = Scene::Coupling::SheetGuard;
    const G g = scene.coupling.sheet_guard;
    const bool paper =
        scene.has(Module::Capillary) && scene.capillary.model == Scene::AbsorptionModel::Paper;
    sheet_guard_on_ =
        coupling_on_ && scene.has(Module::Contact) && (g == G::On || (g == G::Auto && !paper));
  }
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
  sph_.artificial = static_cast<T>(scene.fluid.artificial_viscosity * scene.fluid.speed_of_sound);
  sph_.no_slip = scene.fluid.no_slip;
  sph_.gravity = vec_cast<T>(scene.gravity);
  sph_.density = scene.solver.density;
  sph_.diffusion =
      static_cast<T>(scene.solver.density_diffusion * 0.5 * h_ * scene.fluid.speed_of_sound);

  build_pipeline();
  if (build == Build::Stages)
    return; // the stage list is all `plan` needs
  const bool split = build == Build::Run && mpi && mpi->size() > 1;
  init_particles(split ? mpi : nullptr);
  update_shapes(0.0);
  if (build == Build::Particles)
    return; // what the split is made from (split_plan)
  init_work_measures();
  // On N ranks each holds what it owns of the fluid and the boundary (init_particles kept it by
  // the first partition), and the whole knit until KnitHalo keeps its share.
  if (split) {
    ranks_.emplace(*mpi, scene_, backend, split_);
    if (fluid_list_) // every rank keeps or builds its lists at the same steps
      fluid_list_->combine_readings([this](T* m, int k) {
        MPI_Allreduce(MPI_IN_PLACE, m, k, std::is_same_v<T, float> ? MPI_FLOAT : MPI_DOUBLE,
                      MPI_MAX, ranks_->mpi().comm());
      });
    ranks_->adopt(std::move(*first_split_), fluid_ ? &*fluid_ : nullptr,
                  boundary_ ? &*boundary_ : nullptr);
    first_split_.reset();
    if (knit_) {
      knit_halo_.emplace(*ranks_, *knit_, coupling_ ? &*coupling_ : nullptr, split_.knit_skin,
                         sheet_guard_width_);
      if (absorption_)
        absorption_ranks_.emplace(*ranks_, *knit_halo_, *knit_, *absorption_);
      knit_halo_->distribute();
    }
    fit_grids_to_region();
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
void SimulationT<T>::init_work_measures() {
  bool handles = false;
  for (const auto& p : scene_.knit.pins)
    handles = handles || (knit_on_ && norm(p.velocity) > 0);
  if (!moving_ && !handles)
    return;
  work_ = exec::DeviceBuffer<double>(ex_.backend, 0, "watchdog.work");
  work_.assign(std::vector<double>{0.0});
  if (moving_)
    init_contact_work();
  if (knit_on_)
    knit_->measure_work(handles ? work_.data() : nullptr, contact_work(nullptr));
}

template <typename T>
void SimulationT<T>::init_contact_work() {
  // The fixed point's unit: 2^-50 of the scene's energy scale (its whole mass lifted through the
  // domain's height, or moving at the speed of sound or the fastest solid's speed), so one
  // correction rounds by 1e-15 of it and the sum holds 2^13 of it. Every rank sampled the whole
  // scene (before the split).
  double mass = whole_fluid_mass_, speed = fluid_on_ ? scene_.fluid.speed_of_sound : 0.0;
  if (knit_on_)
    for (const T m : knit_->set().m.to_host())
      mass += double(m);
  for (const auto& o : scene_.obstacles)
    speed = std::max(speed, norm(o.velocity));
  const Vec3d span = scene_.domain.max - scene_.domain.min;
  const double energy = mass * (norm(scene_.gravity) * norm(span) + speed * speed);
  contact_unit_ = std::ldexp(energy > 0 ? energy : 1.0, -50);
  contact_work_ = exec::DeviceBuffer<std::uint64_t>(ex_.backend, 0, "watchdog.work");
  contact_work_.assign(std::vector<std::uint64_t>{0});
}

template <typename T>
void SimulationT<T>::measure_boundary_work() {
  BoundaryNeighbours<T> b = boundary_neighbours();
  b.obstacle = boundary_->obstacle.data();
  b.shapes = shapes_.data();
  const std::uint32_t* owned =
      ranks_ && fluid_->size() != ranks_->fluid_owned_count() ? ranks_->owned_flags() : nullptr;
  sph_mover_work(ex_, sph_, fluid_->view(), b, owned, static_cast<T>(dt_), work_.data());
}

template <typename T>
SplitInputs SimulationT<T>::split_inputs() {
  SplitInputs in;
  in.skin = skin_;
  const KnitFluidCoupling<T>* c = coupling_ ? &*coupling_ : nullptr;
  // With the coupling, a knit point may stray half the knit's skin (one support radius)
  // outside the region it is owned by until its ghosts are chosen anew: the fluid's ghosts
  // reach that much farther.
  in.knit_skin = c ? h_ : 0.0;
  if (c)
    in.coupling_reach =
        std::max(double(coupling_reach(c->params())), c->params().capillary ? h_ : 0.0) +
        0.5 * in.knit_skin;
  if (knit_)
    in.knit_width = KnitHalo<T>::base_width(*knit_, c, sheet_guard_width_);
  return in;
}

template <typename T>
PartitionReport SimulationT<T>::split_plan(int ranks) {
  const HaloWidths w = halo_widths(scene_, split_inputs());
  std::vector<Vec3<T>> fx, bx;
  if (fluid_)
    fx = fluid_->x.to_host();
  if (boundary_)
    bx = boundary_->x.to_host();
  const std::span<const Vec3<T>> knit = all_knit_positions();
  const PhaseCosts costs = initial_costs(scene_);
  const Decomposition d = first_partition<T>(scene_, w, costs, ranks, fx, bx, knit);
  return describe_partition<T>(scene_, d, w, costs, {std::span<const Vec3<T>>(fx), bx, knit},
                               fluid_on_ || boundary_on_ ? &whole_grid_ : nullptr);
}

template <typename T>
void SimulationT<T>::init_particles(const comm::MpiContext* split_over) {
  const int span = static_cast<int>(scene_.solver.cell_span);
  // The fluid's and the boundary's grids (on N ranks each rank's a window of it, made once the
  // partition is known: fit_grids_to_region): cells reach the support plus the lists' skin, so a
  // walk of the grid stays exact between the lists' builds (no point has moved more than the
  // skin since the sort; SphLists).
  if (fluid_on_ || boundary_on_)
    whole_grid_ = whole_grid<T>(scene_);
  if (knit_on_)
    knit_.emplace(scene_, ex_, split_over != nullptr);
  // The knit and the coupling first: the split's widths come from them.
  if (coupling_on_)
    init_coupling();
  // No rank holds the whole scene, on its backend or its host, nor reads it whole: on N ranks
  // each samples a share of every lattice's layers for the first partition's box and counts
  // (combined over the ranks: every rank computes the same partition) and the samples' count a
  // layer, then the samples in its region, each with its id: the n-th sample's id is n on any
  // rank count (domain/SceneSampler).
  const double dp = scene_.fluid.spacing;
  std::optional<SceneSampler> fluid_samples, wall_samples;
  std::vector<std::uint64_t> fluid_layers, wall_layers; // each layer's samples (N ranks)
  if (fluid_on_)
    fluid_samples.emplace(scene_, SceneSampler::Kind::Fluid, dp, 0.0);
  if (boundary_on_)
    wall_samples.emplace(scene_, SceneSampler::Kind::Boundary, dp, h_);
  std::array<Vec3d, 2> region{};
  if (split_over) {
    split_ = split_inputs();
    const auto knit = all_knit_positions();
    const int ranks = split_over->size(), rank = split_over->rank();
    // This rank's layers of a sampler, handed to the partition as T (as the run keeps them);
    // each layer's count noted (the same both times the partition calls it).
    const auto share = [&](const SceneSampler& from,
                           std::vector<std::uint64_t>& layers) -> PointSource<T> {
      return [&from, &layers, ranks, rank](const std::function<void(const Vec3<T>&)>& f) {
        const int all = from.layers();
        const int first = int(std::int64_t(all) * rank / ranks),
                  last = int(std::int64_t(all) * (rank + 1) / ranks);
        const auto counts =
            from.layer_samples(first, last, 0, [&](const Sample& q) { f(vec_cast<T>(q.x)); });
        layers.assign(all, 0);
        std::copy(counts.begin(), counts.end(), layers.begin() + first);
      };
    };
    std::array<PointSource<T>, kPhases> points;
    if (fluid_on_)
      points[static_cast<int>(Phase::Fluid)] = share(*fluid_samples, fluid_layers);
    if (boundary_on_)
      points[static_cast<int>(Phase::Boundary)] = share(*wall_samples, wall_layers);
    // The knit is held whole by every rank: counted on rank 0 alone (the counts are summed).
    points[static_cast<int>(Phase::Knit)] = [&](const std::function<void(const Vec3<T>&)>& f) {
      if (rank == 0)
        for (const auto& q : knit)
          f(q);
    };
    first_split_.emplace(first_partition<T>(scene_, halo_widths(scene_, split_),
                                            initial_costs(scene_), ranks, points,
                                            point_shares(*split_over)));
    split_over->sum_in_place(fluid_layers);
    split_over->sum_in_place(wall_layers);
    region = first_split_->region_box(rank);
  }
  // Whether this rank keeps a sample (as owned_rows chooses: its position in T; `owns` says why
  // it is out of line).
  const auto keeps = [&](const Vec3<T>& q) {
    return !first_split_ || owns(*first_split_, split_over->rank(), q);
  };
  // One rank reads every sample; N ranks the samples of their region, widened by a spacing (a
  // sample's position in T is rounded off its double; the sampler adds the jitter's reach).
  // Returns the scene's sample count.
  const auto samples_of = [&](const SceneSampler& from, std::vector<std::uint64_t>& layers,
                              const SampleSink& f) {
    if (!first_split_)
      layers = from.layer_samples(0, from.layers(), 0, f);
    else
      from.samples_in(region[0], region[1], dp, layers, f);
    return std::accumulate(layers.begin(), layers.end(), std::uint64_t(0));
  };
  if (fluid_on_) {
    const double m = lattice_particle_mass(scene_.solver.kernel, scene_.fluid.support, dp,
                                           scene_.fluid.rest_density);
    // The continuity equation's start (summation recomputes the density).
    const bool hydrostatic =
        continuity() && scene_.fluid.initial_density == Scene::Fluid::InitialDensity::Hydrostatic;
    std::vector<Vec3<T>> xs, vs;
    std::vector<std::uint64_t> ids;
    FluidSamples mine; // in double, for the hydrostatic start
    const std::uint64_t count = samples_of(*fluid_samples, fluid_layers, [&](const Sample& s) {
      const Vec3<T> q = vec_cast<T>(s.x);
      if (keeps(q)) {
        xs.push_back(q);
        vs.push_back(vec_cast<T>(s.v));
        ids.push_back(s.id);
        if (hydrostatic) {
          mine.x.push_back(s.x);
          mine.v.push_back(s.v);
        }
      }
    });
    const std::size_t n = xs.size();
    std::vector<T> rho(n, static_cast<T>(scene_.fluid.rest_density));
    if (hydrostatic) {
      const auto eos = scene_eos<double>(scene_);
      // One rank holds every sample already. N ranks sample their samples' columns again: the
      // region, widened by a column's width across gravity and open along it (the whole scene where
      // gravity is off the axes).
      const auto columns = [&](const FluidSampleSink& f) {
        const SampleSink to = [&](const Sample& q) { f(q.x, q.v); };
        const Vec3d& g = scene_.gravity;
        const int along = (g.y == 0 && g.z == 0)   ? 0
                          : (g.x == 0 && g.z == 0) ? 1
                          : (g.x == 0 && g.y == 0) ? 2
                                                   : -1;
        if (along < 0) {
          fluid_samples->layer_samples(0, fluid_samples->layers(), 0, to);
          return;
        }
        Vec3d lo = region[0], hi = region[1];
        (&lo.x)[along] = -std::numeric_limits<double>::infinity();
        (&hi.x)[along] = std::numeric_limits<double>::infinity();
        fluid_samples->samples_in(lo, hi, 2 * dp, fluid_layers, to);
      };
      const std::vector<double> r =
          first_split_ ? hydrostatic_density(mine, columns, scene_.gravity, dp, eos)
                       : hydrostatic_density(mine, scene_.gravity, dp, eos);
      for (std::size_t k = 0; k < n; ++k)
        rho[k] = static_cast<T>(r[k]);
    }
    fluid_.emplace(ex_.backend);
    fluid_->resize(n);
    fluid_->x.assign(xs);
    fluid_->v.assign(vs);
    fluid_->a.assign(std::vector<Vec3<T>>(n, Vec3<T>{}));
    fluid_->m.assign(std::vector<T>(n, static_cast<T>(m)));
    fluid_->rho.assign(rho);
    // Written by the first density pass; zero before it so that a split run's first migration
    // and growth copy written values (compute-sanitizer initcheck).
    fluid_->p.assign(std::vector<T>(n, T(0)));
    fluid_->drho.assign(std::vector<T>(n, T(0)));
    fluid_->drho_prev.assign(std::vector<T>(n, T(0)));
    fluid_->id.assign(ids);
    next_fluid_id_ = count;
    // The whole fluid's mass as one rank sums its particles' (init_contact_work's scale).
    for (std::uint64_t i = 0; i < count; ++i)
      whole_fluid_mass_ += double(static_cast<T>(m));
    if (!split_over)
      fluid_grid_.emplace(ex_.backend, whole_grid_, span,
                          static_cast<int>(scene_.solver.cell_order), "fluid.grid");
    if (scene_.solver.neighbour_list != Scene::Solver::NeighbourLists::Off)
      fluid_list_.emplace(ex_.backend, static_cast<T>(skin_));
  }
  if (boundary_on_) {
    // Lattice particles: each stands for the volume of one lattice site, 1 / sum W.
    const double volume =
        lattice_particle_mass(scene_.solver.kernel, scene_.fluid.support, dp, 1.0);
    std::vector<Vec3<T>> xs;
    std::vector<T> vol;
    std::vector<std::uint64_t> ids;
    std::vector<std::uint32_t> obstacle;
    samples_of(*wall_samples, wall_layers, [&](const Sample& s) {
      const Vec3<T> q = vec_cast<T>(s.x);
      if (keeps(q)) {
        xs.push_back(q);
        vol.push_back(static_cast<T>(volume * s.volume_scale));
        ids.push_back(s.id);
        obstacle.push_back(s.obstacle);
      }
    });
    const std::size_t n = xs.size();
    boundary_.emplace(ex_.backend);
    boundary_->resize(n);
    boundary_->x.assign(xs);
    boundary_->x0.assign(xs);
    boundary_->obstacle.assign(obstacle);
    boundary_->volume.assign(vol);
    boundary_->id.assign(ids);
    if (!split_over)
      boundary_grid_.emplace(ex_.backend, whole_grid_, span,
                             static_cast<int>(scene_.solver.cell_order), "boundary.grid");
  }
}

template <typename T>
void SimulationT<T>::init_absorption(const CouplingParams<T>& cp) {
  const PoreNetwork net = pore_network(scene_, build_knit(scene_));
  const double rho0 = scene_.fluid.rest_density;
  std::vector<T> dry(net.dry.begin(), net.dry.end()),
      capacity(net.capacity.begin(), net.capacity.end());
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
  absorption_.emplace(ex_.backend, ap, dry, capacity, net.links, net.conductance);
}

template <typename T>
void SimulationT<T>::init_coupling() {
  const CouplingParams<T> p = coupling_params<T>(scene_, knit_->longest_spacing());
  const double reach = coupling_fluid_reach(scene_, p);
  // The coupling walks the fluid's grid, which "verlet" lists sort only now and then: a walk
  // finds every particle within h of a point (SphLists), so the reach must fit in that.
  if (skin_ > 0 && reach > h_)
    throw Error("solver.neighbour_list = \"verlet\": the knit-fluid coupling reaches " +
                std::to_string(reach) + " m, more than the fluid's support (" + std::to_string(h_) +
                " m); use neighbour_list = \"off\"");
  coupling_.emplace(ex_.backend, scene_.solver.kernel, p, coupling_grid(scene_, p));
  if (p.capillary && scene_.capillary.model == Scene::AbsorptionModel::Conserving)
    init_absorption(p);
  if (sheet_guard_on_)
    init_sheet_guard();
  if (!p.contact)
    return;
  const CouplingLimits lim = coupling_limits(scene_, double(p.dem.k), knit_->min_free_mass());
  knit_->set_substep_limit(lim.knit_substep);
  coupling_fluid_limit_ = lim.fluid_step;
}

template <typename T>
void SimulationT<T>::init_sheet_guard() {
  const KnitMesh mesh = build_knit(scene_);
  const SheetFaces sheet = build_sheet_faces(mesh);
  double longest = 0;
  for (const auto& f : sheet.faces)
    for (int e = 0; e < 3; ++e)
      longest = std::max(longest, norm(mesh.x[f[e]] - mesh.x[f[(e + 1) % 3]]));
  // On N ranks the ghosts hold every face with a corner within the guard's reach of an owned
  // particle (its other corners within one longest edge of that one), the faces stretched by up
  // to half (the knit halo's allowance for springs), a step of twice the CFL's share of the
  // support, the fluid straying a skin.
  sheet_guard_width_ =
      1.5 * longest * (1 + 1 / std::sqrt(3.0)) + 2 * scene_.solver.cfl * h_ + skin_;
  sheet_guard_.emplace(ex_.backend, sheet.faces, sheet.offsets, sheet.ids,
                       static_cast<T>(0.1 * scene_.fluid.spacing),
                       static_cast<T>(scene_.fluid.speed_of_sound));
  sheet_count_.assign(std::vector<std::uint64_t>{0});
  sheet_x0_ = exec::DeviceBuffer<Vec3<T>>(ex_.backend, 0, "sheet_guard.knit_x0");
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
        },
        true); // takes no step size
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
    pipeline_.add(
        "coupling.begin", coupling_module,
        capillary ? "knit saturation (Eq. 9), Leverett J (Eq. 11), capillary pressure "
                    "(Eq. 10) from the fluid around each knit point; fluid impulses "
                    "cleared"
                  : "knit grid for the contact; fluid impulses cleared",
        [this] { begin_coupling(); }, true); // waits for the step's size itself
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
          typename KnitSystem<T>::Couple couple;
          if (coupling_on_)
            couple = [this](T weight, const KnitForceTerms<T>& own,
                            const WatchedCopies<T>& self_copies) {
              coupling_->add_forces(ex_, knit_->set(), fluid_side(), weight, &own, self_copies);
            };
          if (knit_halo_ && !coupling_on_) { // else coupling.begin did
            if (!fluid_on_)                  // else the fluid's sort checks the balance
              ranks_->balance(steps_, nullptr, nullptr, &knit_->set().x, knit_->owned());
            knit_halo_->begin(knit_->expected_motion(dt_));
          }
          if (sheet_guard_on_) { // the faces' start, for the guard after the fluid's drift
            sheet_x0_.resize(knit_->set().size());
            sheet_x0_.copy_from(knit_->set().x, sheet_x0_.size());
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
                    if (!sheet_guard_on_) // else after the sheet's guard
                      after_drift();
                    settle_step();
                  });
  else if (fluid_on_)
    pipeline_.add("integrate.kick_drift", "fluid", "velocity Verlet: half kick, drift", [this] {
      drop_coupled_ghosts();
      auto f = fluid_->view();
      kick_drift(ex_, f.x, f.v, f.a, f.n, static_cast<T>(dt_), damping_keep(dt_),
                 "integrate.kick_drift", {}, planned_dt());
      if (!sheet_guard_on_) // else after the sheet's guard
        after_drift();
      settle_step();
    });
  if (sheet_guard_on_)
    pipeline_.add("coupling.sheet_guard", "contact",
                  "put back fluid particles whose step crossed a face of the knit's sheet "
                  "(tunnelling between the knit's points; counted)",
                  [this] {
                    guard_sheet();
                    after_drift();
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
                                         guard_count_.data(), "boundary.guard", contact_work(f.m));
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
                      bool stale = false;
                      {
                        stage_parts::Scope part("grid.fluid: the lists' check");
                        stale = fluid_list_->stale_after(
                            ex_, *fluid_, static_cast<T>(fluid_step_motion()), moving_, meanwhile);
                      }
                      if (stale) {
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
                  std::string(continuity()
                                  ? "pressure (Eq. 3), viscosity (Eq. 4), gravity; density rate "
                                    "(continuity, delta-SPH diffusion) and the density's step"
                                  : "pressure (Eq. 3), viscosity (Eq. 4), gravity") +
                      (shifting() ? "; particle shifting (Fickian, off the free surface)" : ""),
                  [this] { fluid_forces(static_cast<T>(dt_)); });
    if (boundary_on_ && moving_)
      pipeline_.add("boundary.work", "boundary",
                    "the moving solids' work on the fluid over the step (the watchdog's energy "
                    "budget)",
                    [this] { measure_boundary_work(); });
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
                      const T dt = static_cast<T>(dt_), keep = damping_keep(dt_);
                      // On N ranks the forces' refresh may still be in flight (fluid_forces):
                      // the owned rows first, the ghosts once their accelerations are in.
                      const bool split = ranks_ && ranks_->forces_pending();
                      kick_bounds(ex_, f.v, f.a, f.n, dt, keep, bounds_.data() + 1,
                                  "integrate.kick", split ? ranks_->owned_flags() : nullptr);
                      if (split) {
                        ranks_->finish_forces();
                        kick_rows(ex_, f.v, f.a, ranks_->ghost_rows(), dt, keep, "integrate.kick");
                      }
                      fluid_bounds_ready_ = true;
                    });
  }
}

template SimulationT<float>::SimulationT(const Scene&, exec::Backend, Build,
                                         const comm::MpiContext*);
template SimulationT<double>::SimulationT(const Scene&, exec::Backend, Build,
                                          const comm::MpiContext*);
template PartitionReport SimulationT<float>::split_plan(int);
template PartitionReport SimulationT<double>::split_plan(int);

std::unique_ptr<Simulation> Simulation::create(const Scene& scene, exec::Backend backend,
                                               const comm::MpiContext* mpi) {
  if (backend == exec::Backend::Cuda && !exec::cuda_available())
    throw Error(exec::cuda_compiled() ? "--device cuda: no CUDA device is visible"
                                      : "--device cuda: this knitflow was built without CUDA");
  if (scene.precision == Precision::Double)
    return std::make_unique<SimulationT<double>>(scene, backend, SimulationT<double>::Build::Run,
                                                 mpi);
  return std::make_unique<SimulationT<float>>(scene, backend, SimulationT<float>::Build::Run, mpi);
}

} // namespace kf
