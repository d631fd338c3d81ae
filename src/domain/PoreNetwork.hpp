#pragma once
// The knit as a pore network for the conserving absorption's Darcy flow (docs/PHYSICS.md): its
// links (in-layer stretch springs and the straight springs between layers), their conductances
// and each point's dry mass and capacity. Built once from the rest mesh, for the run
// (SimulationT::init_absorption) and for the plan (its Darcy substeps a step:
// kf::darcy_stable_substep).
#include "domain/KnitBuilder.hpp"
#include "domain/Scene.hpp"

#include <array>
#include <cstdint>
#include <vector>

namespace kf {

struct PoreNetwork {
  std::vector<std::array<std::uint32_t, 2>> links;
  std::vector<double> conductance;   // a link's rho0 kappa / mu (V_i + V_j) / (2 L^2)
  std::vector<double> dry, capacity; // a point's dry mass and phi V rho0 [kg]
};

PoreNetwork pore_network(const Scene& scene, const KnitMesh& mesh);

} // namespace kf
