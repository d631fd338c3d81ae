// `knitflow plan`: the scene's stages, particle counts and step limits without running it.
#include "domain/PoreNetwork.hpp"
#include "domain/SimulationT.hpp"
#include "kernels/coupling/Absorption.hpp"

#include <algorithm>
#include <cmath>

namespace kf {

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

/// Points (i, j, k) of the cubic lattice of unit spacing closer than q to the origin: a row of
/// the fluid's lists at the start, where fluid and walls fill one lattice; `above_a_wall`, only
/// those with k >= 1, a wall particle's row under the fluid of a flat wall (its first layer a
/// spacing above the wall's).
std::uint32_t lattice_points_within(double q, bool above_a_wall) {
  const int n = static_cast<int>(std::floor(q));
  std::uint32_t c = 0;
  for (int i = -n; i <= n; ++i)
    for (int j = -n; j <= n; ++j)
      for (int k = above_a_wall ? 1 : -n; k <= n; ++k)
        c += double(i * i + j * j + k * k) < q * q;
  return c;
}

} // namespace

PlanReport Simulation::plan(const Scene& scene) {
  PlanReport r;
  const bool dbl = scene.precision == Precision::Double;
  std::unique_ptr<Simulation> shell;
  if (dbl)
    shell.reset(
        new SimulationT<double>(scene, exec::Backend::Cpu, SimulationT<double>::Build::Stages));
  else
    shell.reset(
        new SimulationT<float>(scene, exec::Backend::Cpu, SimulationT<float>::Build::Stages));
  for (const auto& s : shell->pipeline().stages())
    r.stages.push_back({s.name + " [" + s.module + "]", s.what});
  r.support_radius = scene.support_radius();
  for (const auto& o : scene.obstacles)
    r.obstacles.push_back(describe_obstacle(o));
  r.bytes_solids = dbl ? RigidShapes<double>(scene).bytes() : RigidShapes<float>(scene).bytes();
  const double h = r.support_radius;
  const auto geo = whole_grid<double>(scene); // the run's fluid and boundary grid on one rank
  r.grid[0] = geo.nx;
  r.grid[1] = geo.ny;
  r.grid[2] = geo.nz;
  constexpr std::size_t kGridCellBytes = 3 * sizeof(std::uint32_t); // start, end, rank
  const std::size_t grid_bytes = std::size_t(geo.cells()) * kGridCellBytes;
  if (scene.has(Module::Fluid)) {
    r.fluid = 0; // counted, not kept: a plan of a scene too large for one host still runs
    for_each_fluid_sample(scene, [&](const Vec3d&, const Vec3d&) { ++r.fluid; });
    r.bytes_fluid = r.fluid * (dbl ? FluidSet<double>::bytes_per_particle()
                                   : FluidSet<float>::bytes_per_particle());
    r.bytes_grid += grid_bytes;
    r.grid_bytes_per_cell += kGridCellBytes;
  }
  if (scene.has(Module::Boundary)) {
    r.boundary = 0;
    for_each_boundary_sample(scene, scene.fluid.spacing, h,
                             [&](const Vec3d&, std::uint32_t, double) { ++r.boundary; });
    r.bytes_boundary = r.boundary * (dbl ? BoundarySet<double>::bytes_per_particle()
                                         : BoundarySet<float>::bytes_per_particle());
    r.bytes_grid += grid_bytes;
    r.grid_bytes_per_cell += kGridCellBytes;
  }
  if (scene.has(Module::Fluid) &&
      scene.solver.neighbour_list != Scene::Solver::NeighbourLists::Off) {
    const bool verlet = scene.solver.neighbour_list == Scene::Solver::NeighbourLists::Verlet;
    const double reach = h * (1 + (verlet ? scene.solver.neighbour_skin : 0));
    const double q = reach / scene.fluid.spacing;
    r.list_most = lattice_points_within(q, false);
    r.wall_list_most = lattice_points_within(q, true);
    const bool walls = r.boundary > 0;
    const auto fp = dbl ? SphLists<double>::footprint(r.list_most, r.wall_list_most, verlet, walls)
                        : SphLists<float>::footprint(r.list_most, r.wall_list_most, verlet, walls);
    r.list_bytes_fluid = fp.per_fluid;
    r.list_bytes_boundary = fp.per_boundary;
    r.bytes_lists = static_cast<std::size_t>(double(r.fluid) * fp.per_fluid +
                                             double(r.boundary) * fp.per_boundary);
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
  double pressure_scale = 0; // the capillary's sigma / sqrt(kappa / phi), for the Darcy substeps
  if (scene.has(Module::Knit)) {
    // Built in the scene's precision on the host (the CPU backend): plan never touches a device.
    auto count = [&](auto&& knit) {
      r.knit = knit.size();
      r.springs = knit.springs().springs();
      r.volume_cells = knit.volume_cells();
      if (const auto* sc = knit.self_contact_params())
        r.knit_self_radius = double(sc->radius);
      r.bytes_knit = knit.bytes();
      r.bytes_knit_rows = knit.row_bytes();
      if (scene.has(Module::Contact) || scene.has(Module::Capillary)) {
        const auto p = coupling_params<double>(scene, knit.longest_spacing());
        r.coupling_reach = p.reach;
        pressure_scale = p.pressure_scale;
        r.coupling_stiffness = p.contact ? p.dem.k : 0;
        if (scene.has(Module::Fluid)) { // in the knit's precision, the scene's
          using U = decltype(knit.mesh_rest()[0].x);
          const GridGeometry<U> grid =
              coupling_grid(scene, coupling_params<U>(scene, knit.longest_spacing()));
          const auto fp = KnitFluidCoupling<U>::footprint(grid);
          const auto& x = knit.mesh_rest();
          r.coupling_near = std::min<std::size_t>(
              r.fluid,
              KnitFluidCoupling<U>::near_bound(grid, x.data(), x.size(), scene.fluid.spacing));
          r.coupling_bytes_grid = fp.grid;
          r.coupling_bytes_fluid = fp.per_fluid;
          r.coupling_bytes_knit = fp.per_knit;
          r.coupling_bytes_row = fp.per_row;
          r.bytes_coupling = fp.bytes(r.fluid, r.knit, r.coupling_near);
        }
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
  // The run's typical step: the CFL condition at the fluid's fall from its top, sqrt(2 g H) (none
  // where the scene damps its motion: a rest state settling), where that is below the initial
  // step; the cost model's steps (domain/CostModel).
  r.run_dt = r.initial_dt;
  if (scene.has(Module::Fluid) && !scene.fluid.blocks.empty()) {
    double top = scene.fluid.blocks.front().max.z;
    for (const auto& b : scene.fluid.blocks)
      top = std::max(top, b.max.z);
    const double g = norm(scene.gravity);
    if (s.damping <= 0 && g > 0)
      r.fall_speed = std::sqrt(2 * g * std::max(top - scene.domain.min.z, 0.0));
    r.run_dt =
        std::min(r.run_dt, s.cfl * h / (scene.fluid.speed_of_sound + std::max(vmax, r.fall_speed)));
  }
  r.run_steps = std::ceil(scene.end_time / r.run_dt);
  if (r.knit > 0 && scene.has(Module::Fluid) && scene.has(Module::Capillary) &&
      scene.capillary.model == Scene::AbsorptionModel::Conserving) {
    const PoreNetwork net = pore_network(scene, build_knit(scene));
    r.darcy_substeps =
        std::min(1e4, std::ceil(r.run_dt / darcy_stable_substep(net.capacity, net.links,
                                                                net.conductance, pressure_scale)));
  }
  if (scene.output.enabled && scene.output.interval > 0)
    r.output_frames = std::floor(scene.end_time / scene.output.interval + 1e-9) + 1;
  return r;
}

double rank_bytes(const PlanReport& r, const RankShare& s, int ranks) {
  const auto share = [&](std::size_t bytes, std::size_t all, std::size_t points) {
    return all > 0 ? double(bytes) / double(all) * double(points) : 0.0;
  };
  constexpr int F = static_cast<int>(Phase::Fluid), B = static_cast<int>(Phase::Boundary),
                K = static_cast<int>(Phase::Knit);
  double b = double(r.bytes_solids) + double(s.grid_cells) * double(r.grid_bytes_per_cell);
  b += share(r.bytes_fluid, r.fluid, s.owned[F] + s.ghosts[F]);
  b += share(r.bytes_boundary, r.boundary, s.owned[B] + s.ghosts[B]);
  b += r.list_bytes_fluid * double(s.owned[F] + s.ghosts[F]) +
       r.list_bytes_boundary * double(s.owned[B] + s.ghosts[B]);
  b += share(r.bytes_knit - r.bytes_knit_rows, r.knit, s.owned[K] + s.ghosts[K]);
  b += share(r.bytes_knit_rows, r.knit, s.owned[K]);
  if (r.bytes_coupling > 0) { // its grid is the domain's on every rank; rows for ghosts too
    const double knit = double(s.owned[K] + s.ghosts[K]);
    const double near = double(r.coupling_near) * knit / double(std::max<std::size_t>(r.knit, 1));
    b += double(r.coupling_bytes_grid) +
         double(r.coupling_bytes_fluid) * double(s.owned[F] + s.ghosts[F]) +
         double(r.coupling_bytes_knit) * knit +
         double(r.coupling_bytes_row) *
             double(KnitFluidCoupling<float>::rows_for(static_cast<std::size_t>(near),
                                                       std::size_t(s.owned[F] + s.ghosts[F])));
  }
  if (ranks > 1 && r.knit > 0) // KnitHalo's id -> local table, the cells' slots (4 bytes each)
    b += 4.0 * double(r.knit + r.volume_cells);
  return b;
}

PartitionReport Simulation::plan_split(const Scene& scene, int ranks) {
  if (scene.precision == Precision::Double)
    return SimulationT<double>(scene, exec::Backend::Cpu, SimulationT<double>::Build::Particles)
        .split_plan(ranks);
  return SimulationT<float>(scene, exec::Backend::Cpu, SimulationT<float>::Build::Particles)
      .split_plan(ranks);
}

} // namespace kf
