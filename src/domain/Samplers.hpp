#pragma once
// Turns scene geometry into particles: fluid blocks into lattices, rigid surfaces into boundary
// particles. Host-only and deterministic (the same scene always gives the same particles in the
// same order), so `plan` can count particles without a device.
#include "core/SolverOptions.hpp"
#include "core/Vec3.hpp"
#include "domain/Scene.hpp"
#include "kernels/sph/Eos.hpp"

#include <cstdint>
#include <vector>

namespace kf {

/// Cubic lattice filling [min, max) at spacing dp, particles at cell centres.
std::vector<Vec3d> sample_fluid_block(const FluidBlock& block, double dp);

struct FluidSamples {
  std::vector<Vec3d> x, v; // position and initial velocity
  std::size_t size() const { return x.size(); }
};

/// All fluid particles of the scene, blocks in order, less the lattice points in or at a solid.
FluidSamples sample_fluid(const Scene& scene);

/// The density each fluid sample starts with under the weight of the fluid above it (continuity
/// density, fluid.initial_density = "hydrostatic"): samples at rest (v = 0) are binned in columns
/// dp wide along gravity; each contiguous run of a column (a gap over 1.5 dp starts a new one)
/// has its top sample dp / 2 below the surface, and a sample at depth d below that surface has
/// P = rho0 |g| d and the EOS's density. Moving samples, and all without gravity, start at rho0.
std::vector<double> hydrostatic_density(const FluidSamples& fs, const Vec3d& gravity, double dp,
                                        const Eos<double>& eos);

/// Particle mass that makes an interior particle of a perfect lattice sit at rest density with
/// the chosen kernel (so a fluid at rest starts without a pressure jolt).
double lattice_particle_mass(KernelType kernel, double support, double dp, double rho0);

struct BoundarySamples {
  std::vector<Vec3d> x;
  std::vector<std::uint32_t> obstacle; // index into scene.obstacles, kWallObstacle for walls
  std::vector<double> volume_scale;    // volume / dp^3 (1 unless the lattice is stretched)
};

/// Boundary particles filling a shell `depth` thick (the kernel support) inside every solid: the
/// domain walls and each obstacle, on the fluid's lattice of spacing dp.
BoundarySamples sample_boundaries(const Scene& scene, double dp, double depth);

} // namespace kf
