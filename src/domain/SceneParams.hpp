#pragma once
// Kernel parameters derived from a scene, shared by the simulation and `knitflow plan`.
#include "domain/Samplers.hpp" // lattice_particle_mass
#include "domain/Scene.hpp"
#include "kernels/coupling/KnitFluidCoupling.hpp"
#include "kernels/sph/Sph.hpp"

#include <algorithm>
#include <cmath>

namespace kf {

/// The capillary pressure's scale sigma / sqrt(kappa / phi) [Pa]: P_c = scale J(s) (Eq. 10).
inline double capillary_pressure_scale(const Scene& s) {
  return s.capillary.sigma / std::sqrt(s.capillary.permeability / s.capillary.porosity);
}

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
  // The reach at a fluid spacing dp: R_f + R_k.
  auto reach_at = [&](double dp) {
    const double rf = s.coupling.fluid_radius > 0 ? s.coupling.fluid_radius : 0.5 * dp;
    const double rk = s.coupling.knit_radius > 0
                          ? s.coupling.knit_radius
                          : std::max(s.knit.radius(), 0.8 * knit_spacing - rf);
    return rf + rk;
  };
  const double reach = reach_at(s.fluid.spacing);
  // The stiffness that stops the particle of the spacing it is set for (the preview's: the
  // scene's own, whose reach it takes too) at c/10 within half that reach.
  const double dk =
      s.coupling.stiffness_spacing > 0 ? s.coupling.stiffness_spacing : s.fluid.spacing;
  const double reach_k = reach_at(dk);
  const double mf =
      lattice_particle_mass(s.solver.kernel, s.fluid.support, dk, s.fluid.rest_density);
  const double c = s.fluid.speed_of_sound;
  const double k = s.coupling.stiffness > 0
                       ? s.coupling.stiffness
                       : mf * (0.1 * c) * (0.1 * c) / (0.25 * reach_k * reach_k);
  p.reach = static_cast<T>(reach);
  p.dem = {static_cast<T>(k), static_cast<T>(s.coupling.damping_ratio),
           static_cast<T>(s.coupling.friction)};
  p.h = static_cast<T>(s.support_radius());
  p.porosity = static_cast<T>(s.capillary.porosity);
  p.rho0 = static_cast<T>(s.fluid.rest_density);
  p.pressure_scale = static_cast<T>(capillary_pressure_scale(s));
  p.volume_per_mass = static_cast<T>(s.knit.thickness / s.knit.mass_per_area);
  p.gravity = vec_cast<T>(s.gravity);
  return p;
}

/// How far the coupling reaches into the fluid: the contact's reach, or with the capillary model
/// the fluid's support (its saturation's kernel).
template <typename T>
double coupling_fluid_reach(const Scene& s, const CouplingParams<T>& p) {
  return std::max(double(p.reach), p.capillary ? s.support_radius() : 0.0);
}

/// The coupling's knit grid: over the domain, cells 50% over that reach: a third of the margin
/// is the grid's skin (sorted again when a point moved that far), two thirds the per-step lists'
/// (KnitFluidCoupling).
template <typename T>
GridGeometry<T> coupling_grid(const Scene& s, const CouplingParams<T>& p) {
  return NeighbourGrid<T>::cover(s.domain.min, s.domain.max, 1.5 * coupling_fluid_reach(s, p));
}

/// The scene's equation of state, in the precision U.
template <typename U>
Eos<U> scene_eos(const Scene& s) {
  return {s.fluid.eos, static_cast<U>(s.fluid.rest_density),
          static_cast<U>(s.fluid.speed_of_sound * s.fluid.speed_of_sound),
          static_cast<U>(s.fluid.tait_exponent), s.fluid.clamp_negative_pressure};
}

/// Explicit contact: the knit's substep and the fluid's step each resolve the contact's
/// oscillation for their own mass, with up to kMaxContacts partners at once.
struct CouplingLimits {
  double knit_substep = 1e30, fluid_step = 1e30;
};
inline CouplingLimits coupling_limits(const Scene& s, double k, double knit_min_mass) {
  constexpr double kMaxContacts = 6;
  const double factor = s.knit.spring_factor;
  const double mf = lattice_particle_mass(s.solver.kernel, s.fluid.support, s.fluid.spacing,
                                          s.fluid.rest_density);
  return {factor * std::sqrt(knit_min_mass / (kMaxContacts * k)),
          factor * std::sqrt(mf / (kMaxContacts * k))};
}

} // namespace kf
