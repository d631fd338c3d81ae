// SimulationT<T>'s fluid and boundary passes: the sorts, density, forces and the boundary's
// pressure, each with the halo it reads on N ranks (ghost refreshes just before the pass).
#include "domain/SimulationT.hpp"
#include "domain/StageParts.hpp"
#include "kernels/sph/Shifting.hpp"

namespace kf {

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
  std::optional<stage_parts::Scope> part;
  if (ranks_) {
    part.emplace("grid.fluid: the balance checked (N ranks)");
    // Every [parallel] check_every steps the measured imbalance may share the blocks out anew,
    // from the fluid this rank owns: the ghosts kept since the last sort ("verlet" lists) go
    // first. Otherwise the sort after the rebuild drops them with the leavers (no compaction).
    if (ranks_->balance_due(steps_))
      ranks_->drop_ghosts(ex_, *fluid_);
    if (ranks_
            ->balance(steps_, &*fluid_, boundary_on_ ? &*boundary_ : nullptr,
                      knit_halo_ ? &knit_->set().x : nullptr, knit_halo_ ? knit_->owned() : 0,
                      knit_halo_ ? coupling_pairs() : nullptr)
            .repartitioned) {
      fit_grids_to_region();
      if (boundary_on_)
        sort_boundary();
    }
    // Migration and the ghosts first, then the same sort over owned and ghost particles.
    const auto& d = scene_.domain;
    std::array<bool, 6> walls = d.walls;
    if (!remove_outflow)
      walls.fill(true);
    part.reset(); // the rebuild times its own parts
    // The fluid beside walls goes farther: the ghost walls' pressures are computed here.
    WiderCells<T> beside_walls;
    if (boundary_on_)
      beside_walls = {boundary_grid_->view().geo, boundary_near_.data()};
    const auto gone = ranks_->rebuild(*fluid_, vec_cast<T>(d.min), vec_cast<T>(d.max), walls,
                                      carry.acceleration, beside_walls);
    outflow_particles_ += gone.particles;
    outflow_mass_ += gone.mass;
    part.emplace("grid.fluid: the sort by cell");
    // The rows the rebuild left in place (leavers, the last sort's ghosts) sort last and go.
    const std::size_t rows = fluid_->size();
    fluid_grid_->build_keeping(ex_, fluid_->x.data(), rows,
                               KeepBox<T>::everywhere(ranks_->rebuilt_rows()), fluid_->id.data());
    fluid_->reorder(ex_, fluid_grid_->permutation(), carry);
    const std::size_t kept = fluid_grid_->kept();
    fluid_grid_->drop_outside(kept);
    fluid_->resize(kept);
    ranks_->fluid_sorted(fluid_grid_->permutation(), rows, kept);
  } else if (remove_outflow) {
    part.emplace("grid.fluid: the sort by cell");
    const auto& d = scene_.domain;
    outflow_particles_ +=
        sort_removing_outside(ex_, *fluid_grid_, *fluid_, vec_cast<T>(d.min), vec_cast<T>(d.max),
                              sorted_outflow_mass_.data(), carry);
  } else {
    part.emplace("grid.fluid: the sort by cell");
    fluid_grid_->build(ex_, fluid_->x.data(), fluid_->size(), fluid_->id.data());
    fluid_->reorder(ex_, fluid_grid_->permutation(), carry);
  }
  // For boundary.pressure and the coupling's knit side, which walk this grid until the next
  // sort: a walk from a cell without fluid around is skipped.
  part.emplace("grid.fluid: the occupied cells and the lists");
  if (boundary_on_ || coupling_on_)
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
  // A shift moves a particle at most |v| dt more, v the half kick's (sph_shift): one drift more.
  const double drifts = (solids_.empty() ? 1.0 : 2.0) + (shifting() ? 1.0 : 0.0);
  return drifts * drift * (1 + 1e-6) + rounding;
}

template <typename T>
void SimulationT<T>::fit_grids_to_region() {
  // A grid of the whole domain on every rank would cost each rank the domain's cells (tables,
  // and every pass over cells), however small its share: at 512 ranks, the job's. The window
  // holds every particle this rank sorts (its blocks' particles, the ghosts within their widths
  // of them, the motion since the last rebuild within the skin) in the whole grid's cells.
  if (!ranks_ || (!fluid_on_ && !boundary_on_))
    return;
  const GridGeometry<T>& whole = whole_grid_;
  const GridGeometry<T> geo =
      rank_grid(ranks_->decomposition(), ranks_->rank(), whole, ranks_->widths());
  // (none yet at the start: init_particles leaves them to this)
  const auto& now = fluid_on_ ? fluid_grid_ : boundary_grid_;
  if (now && geo.same_cells(now->geometry()))
    return;
  const int span = static_cast<int>(scene_.solver.cell_span);
  // The sub-cell order of the whole grid (a window's fewer cells might leave room for more
  // levels): a cell's particles then go in the order one rank gives them.
  const int levels = NeighbourGrid<T>::usable_order_levels(
      whole.cells() + 1, static_cast<int>(scene_.solver.cell_order));
  if (fluid_on_) {
    fluid_grid_.emplace(ex_.backend, geo, span, levels, "fluid.grid");
    fluid_near_.resize(0); // the last sort's flags: of the old grid
    if (fluid_list_)
      fluid_list_->forget();
  }
  if (boundary_on_)
    boundary_grid_.emplace(ex_.backend, geo, span, levels, "boundary.grid"); // the caller sorts it
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
    shift_fluid(dt);
    return;
  }
  const auto on_rows = [&](const exec::Rows& rows) { pass(&rows); };
  // With the knit coupled the ghosts stay until the next drift (the coupling reads the fluid
  // around the knit) and take their owners' motion after the kick (refresh_motion: v, a and the
  // density's state): only the owned rows are computed (the ghosts' were 7% of the pass on the
  // pour's 2 ranks, all overwritten).
  if (coupling_on_) {
    ranks_->owned_pass(fluid_->size(), on_rows);
    shift_fluid(dt);
    return;
  }
  // Their work is done: between steps a rank holds only the fluid it owns; with "verlet" lists
  // the ghosts stay until the next sort, taking their owners' state now, so that the kick, the
  // drift and the next density pass give each the values its owner computes.
  if (ranks_->keeps_ghosts()) {
    // Where the next stage is the kick (no shifting, no moving solids' work, no knit), the
    // exchange stays in flight behind the owned rows' kick (its stage finishes it).
    const bool defer = !shifting() && !knit_on_ && !(boundary_on_ && moving_);
    ranks_->refresh_forces(*fluid_, continuity(), on_rows, defer);
    shift_fluid(dt);
  } else {
    ranks_->owned_pass(fluid_->size(), on_rows);
    shift_fluid(dt); // while the ghosts are there: the border's shifts read them
    ranks_->drop_ghosts(ex_, *fluid_);
  }
}

template <typename T>
void SimulationT<T>::shift_fluid(T dt) {
  if (!shifting() || !(dt > T(0)))
    return;
  const auto& s = scene_.solver;
  const ShiftRule<T> rule{static_cast<T>(s.shifting_coefficient),
                          static_cast<T>(s.shifting_surface), dt};
  const std::size_t n = fluid_->size();
  // Scratch written for every owned row before its read: grown without copying (a copy would
  // read the ghosts' slots nothing wrote; the CPU's copy check under Valgrind found it).
  shift_.resize_snug_discarding(n);
  // Every shift read the positions before any moves: the moves in a pass of their own.
  auto find = [&](const exec::Rows& rows) {
    const LocalWork work(ranks_ ? &*ranks_ : nullptr);
    sph_shift(ex_, sph_, fluid_->view(), fluid_grid_->view(), boundary_neighbours(),
              fluid_list_view(), rule, rows, shift_.data());
  };
  auto move = [&](const exec::Rows& rows) {
    const LocalWork work(ranks_ ? &*ranks_ : nullptr);
    sph_apply_shift(ex_, fluid_->view(), rows, shift_.data());
  };
  if (!ranks_) {
    find(exec::Rows{nullptr, n});
    move(exec::Rows{nullptr, n});
    return;
  }
  ranks_->owned_pass(n, find);
  ranks_->owned_pass(n, move);
  // Ghosts that stay (the "verlet" lists', the coupling's) take their owners' positions.
  ranks_->refresh_positions(*fluid_);
}

template <typename T>
void SimulationT<T>::compute_forces() {
  // dt 0: the density stays as it is (continuity), only its rate and the forces are evaluated.
  fluid_density(T(0));
  if (boundary_on_)
    extrapolate_boundary_pressure();
  fluid_forces(T(0));
  // Outside a step no kick follows to finish the forces' refresh (fluid_forces defers it), or,
  // with the knit coupled, to give the ghosts their owners' motion.
  if (ranks_ && ranks_->forces_pending())
    ranks_->finish_forces();
  if (ranks_ && coupling_on_)
    ranks_->refresh_motion(*fluid_);
}

template <typename T>
void SimulationT<T>::extrapolate_boundary_pressure() {
  // The first pass over each build of the walls' lists writes every wall; the next ones skip
  // the dry walls, whose values hold until the next build.
  const ListView<T> walls = fluid_list_ ? fluid_list_->walls() : ListView<T>{};
  const bool dry_written = walls.count && walls_written_ == fluid_list_->walls_builds();
  auto pass = [&](const exec::Rows* rows) {
    const LocalWork work(ranks_ ? &*ranks_ : nullptr);
    if (boundary_->size() > 0)
      boundary_pressure(ex_, sph_, boundary_->view(), fluid_->view(), fluid_grid_->view(),
                        shapes_.data(), fluid_near_.data(), walls, rows, dry_written);
  };
  if (walls.count)
    walls_written_ = fluid_list_->walls_builds();
  if (!ranks_) {
    pass(nullptr);
    return;
  }
  ranks_->walls_pass(boundary_->size(), [&](const exec::Rows& rows) { pass(&rows); });
}

template void SimulationT<float>::update_shapes(double);
template void SimulationT<float>::sort_fluid(bool, typename FluidSet<float>::Carry);
template void SimulationT<float>::fit_grids_to_region();
template double SimulationT<float>::fluid_step_motion() const;
template void SimulationT<float>::sort_boundary();
template BoundaryNeighbours<float> SimulationT<float>::boundary_neighbours();
template void SimulationT<float>::fluid_density(float);
template void SimulationT<float>::fluid_forces(float);
template void SimulationT<float>::shift_fluid(float);
template void SimulationT<float>::compute_forces();
template void SimulationT<float>::extrapolate_boundary_pressure();
template void SimulationT<double>::update_shapes(double);
template void SimulationT<double>::sort_fluid(bool, typename FluidSet<double>::Carry);
template void SimulationT<double>::fit_grids_to_region();
template double SimulationT<double>::fluid_step_motion() const;
template void SimulationT<double>::sort_boundary();
template BoundaryNeighbours<double> SimulationT<double>::boundary_neighbours();
template void SimulationT<double>::fluid_density(double);
template void SimulationT<double>::fluid_forces(double);
template void SimulationT<double>::shift_fluid(double);
template void SimulationT<double>::compute_forces();
template void SimulationT<double>::extrapolate_boundary_pressure();

} // namespace kf
