// SimulationT<T>'s diagnostics (reduced over ranks once per output) and memory use.
#include "comm/JobFigures.hpp"
#include "domain/SimulationT.hpp"

namespace kf {

template <typename T>
Diagnostics SimulationT<T>::diagnostics() const {
  Diagnostics d;
  d.guard_corrections = guard_corrections();
  d.sheet_corrections = sheet_corrections();
  d.fluid_sorts = fluid_sorts_;
  if (fluid_list_ && skin_ > 0) {
    const auto& e = fluid_list_->ends();
    d.list_ends_far = e.far;
    d.list_ends_sheared = e.sheared;
    d.list_skin = static_cast<double>(fluid_list_->skin());
  }
  if (boundary_on_)
    d.boundary = boundary_->size();
  // Each rank's figures over its own particles and points (on N ranks the ghosts are their
  // owners'), the job's made from them at the end.
  double density_error_sum = 0, saturation_sum = 0;
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
      d.coupling_rows = self.coupling_->near_particles();
      d.coupling_list_builds = self.coupling_->list_builds();
      d.coupling_energy = cs.energy;
      d.absorbed_mass = cs.absorbed_mass;
      d.max_saturation = cs.max_saturation;
      d.mean_saturation = cs.mean_saturation;
      saturation_sum = cs.mean_saturation * double(k.owned());
      d.wet_points = cs.wet_points;
      if (absorption_) {
        const AbsorptionStats& st = absorption_->stats();
        const auto a = absorption_->absorbed().to_host();
        d.absorbed_mass = 0;
        for (std::size_t i = 0; i < k.owned(); ++i)
          d.absorbed_mass += double(a[i]);
        d.absorbed_particles = st.absorbed_particles;
        d.emitted_particles = st.emitted_particles;
        d.diffused_mass = st.diffused_mass;
      }
    }
    d.knit_min_rigid_distance = solids_.empty()
                                    ? std::numeric_limits<double>::infinity()
                                    : k.min_rigid_distance(shapes_.data(), shapes_.size());
  }
  if (fluid_on_) {
    if (boundary_on_ && ranks_) {
      const auto& own = ranks_->boundary_owned();
      d.boundary = std::count(own.begin(), own.end(), 1);
    }
    d.outflow_particles = outflow_particles_;
    d.outflow_mass = outflow_mass();
    const auto v = fluid_->v.to_host();
    const auto m = fluid_->m.to_host();
    const auto rho = fluid_->rho.to_host();
    const auto own = fluid_owned_rows(); // on N ranks with the knit coupled, ghosts follow
    d.fluid = std::count(own.begin(), own.end(), 1);
    const double rho0 = scene_.fluid.rest_density;
    for (std::size_t i = 0; i < v.size(); ++i) {
      if (!own[i])
        continue;
      const double v2 = norm2(vec_cast<double>(v[i]));
      d.kinetic_energy += 0.5 * m[i] * v2;
      d.fluid_mass += m[i];
      d.max_speed = std::max(d.max_speed, std::sqrt(v2));
      const double e = (rho[i] - rho0) / rho0;
      d.max_density_error = std::max(d.max_density_error, e);
      density_error_sum += e;
    }
    if (ranks_ && d.fluid == 0) // a rank without fluid has no say in the most
      d.max_density_error = -1e300;
    d.min_rigid_distance =
        solids_.empty()
            ? std::numeric_limits<double>::infinity()
            : static_cast<double>(min_rigid_distance(ex_, fluid_->x.data(), fluid_->size(),
                                                     shapes_.data(), shapes_.size()));
  }
  if (ranks_) {
    // The job's: one collective an operation (comm::JobFigures), every rank naming the same.
    comm::JobFigures job;
    if (knit_on_) {
      job.sum(d.knit);
      for (double* f : {&d.knit_kinetic_energy, &d.knit_elastic_energy, &d.knit_potential_energy,
                        &d.knit_self_energy})
        job.sum(*f);
      job.sum(d.knit_contacts);
      job.sum(d.knit_self_contacts);
      job.min(d.knit_self_min_gap);
      job.min(d.knit_min_rigid_distance);
      if (coupling_) {
        job.sum(d.coupling_contacts);
        job.sum(d.coupling_rows);
        job.sum(d.coupling_energy);
        job.sum(d.absorbed_mass);
        job.max(d.max_saturation);
        job.sum(saturation_sum);
        job.sum(d.wet_points);
        if (absorption_) {
          job.sum(d.absorbed_particles);
          job.sum(d.emitted_particles);
          job.sum(d.diffused_mass);
        }
      }
    }
    if (fluid_on_) {
      std::uint64_t* counts[] = {&d.fluid, &d.boundary};
      for (std::uint64_t* c : counts)
        job.sum(*c);
      for (double* f : {&d.kinetic_energy, &d.fluid_mass, &density_error_sum, &d.outflow_mass})
        job.sum(*f);
      job.max(d.max_speed);
      job.max(d.max_density_error);
      job.min(d.min_rigid_distance);
      job.sum(d.guard_corrections);
      job.sum(d.sheet_corrections);
      job.sum(d.outflow_particles);
    }
    job.reduce(ranks_->mpi());
    if (coupling_)
      d.mean_saturation = d.knit > 0 ? saturation_sum / double(d.knit) : 0.0;
    d.imbalance = ranks_->last_imbalance();
    d.phase_imbalance = ranks_->last_phase_imbalance();
    const auto& spread = ranks_->last_phase_spread();
    std::copy(spread.begin(), spread.end(), d.phase_spread.begin());
    d.pair_weight = ranks_->pair_weight();
    d.repartitions = ranks_->repartitions();
    d.declined_repartitions = ranks_->declined_repartitions();
    d.balanced_declines = ranks_->balanced_declines();
    d.counted_imbalance = ranks_->last_counted_imbalance();
    d.declined_counted = ranks_->declined_counted_imbalance();
    d.repartition_seconds = ranks_->last_repartition_seconds();
    d.partition_seconds = ranks_->last_partition_seconds();
  }
  if (fluid_on_ && d.fluid)
    d.mean_density_error = density_error_sum / double(d.fluid);
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
  if (knit_halo_)
    b += knit_halo_->bytes();
  if (coupling_)
    b += coupling_->bytes();
  return b;
}

template Diagnostics SimulationT<float>::diagnostics() const;
template std::size_t SimulationT<float>::memory_bytes() const;
template Diagnostics SimulationT<double>::diagnostics() const;
template std::size_t SimulationT<double>::memory_bytes() const;

} // namespace kf
