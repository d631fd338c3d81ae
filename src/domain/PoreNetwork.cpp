#include "domain/PoreNetwork.hpp"

#include <algorithm>

namespace kf {

PoreNetwork pore_network(const Scene& scene, const KnitMesh& mesh) {
  // Conductance rho0 kappa / mu times the link's cross-section over its length, (V_i + V_j) /
  // (2 L^2) (exact for a grid's u and v links: V / a^2 = b t / (3 a)).
  const double vpm = scene.knit.thickness / scene.knit.mass_per_area;
  const double rho0 = scene.fluid.rest_density, phi = scene.capillary.porosity;
  const double darcy = rho0 * scene.capillary.permeability / std::max(scene.fluid.viscosity, 1e-6);
  PoreNetwork net;
  for (const Spring& sp : mesh.springs)
    if (sp.kind == SpringKind::Stretch || sp.kind == SpringKind::VolumeStraight) {
      net.links.push_back({sp.i, sp.j});
      net.conductance.push_back(darcy * (mesh.m[sp.i] + mesh.m[sp.j]) * vpm /
                                (2 * sp.rest * sp.rest));
    }
  net.dry.assign(mesh.m.begin(), mesh.m.end());
  net.capacity.resize(mesh.m.size());
  for (std::size_t i = 0; i < mesh.m.size(); ++i)
    net.capacity[i] = phi * mesh.m[i] * vpm * rho0;
  return net;
}

} // namespace kf
