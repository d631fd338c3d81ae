#pragma once
// Turns scene geometry into particles: fluid blocks into lattices, rigid surfaces into boundary
// particles. Host-only and deterministic (the same scene always gives the same particles in the
// same order), so `plan` can count particles without a device.
#include "core/SolverOptions.hpp"
#include "core/Vec3.hpp"
#include "domain/Scene.hpp"
#include "kernels/sph/Eos.hpp"

#include <cstdint>
#include <functional>
#include <vector>

namespace kf {

/// Cubic lattice filling [min, max) at spacing dp, particles at cell centres.
std::vector<Vec3d> sample_fluid_block(const FluidBlock& block, double dp);

struct FluidSamples {
  std::vector<Vec3d> x, v; // position and initial velocity
  std::size_t size() const { return x.size(); }
};

/// Calls f(x, v) for every fluid particle of the scene, blocks in order, less the lattice points
/// in or at a solid: the n-th call is sample n (its id). Nothing is kept: a rank of a split job
/// keeps its share as the samples go by (SimulationT::init_particles), not the whole scene.
using FluidSampleSink = std::function<void(const Vec3d& x, const Vec3d& v)>;
/// What a sampler did: lattice points visited, boxes bounded (domain/LatticeSieve) and points
/// whose distances were evaluated one by one (those near a solid's surface). `by_points` (in):
/// no box bounded, every point by its own distances, as before the sieve (bench_samplers's
/// reference; the same samples).
struct SamplerWork {
  bool by_points = false;
  std::uint64_t points = 0, boxes = 0, tested = 0;
};
void for_each_fluid_sample(const Scene& scene, const FluidSampleSink& f,
                           SamplerWork* work = nullptr);

/// All fluid particles of the scene (for_each_fluid_sample's, in its order).
FluidSamples sample_fluid(const Scene& scene);

/// The density each fluid sample starts with under the weight of the fluid above it (continuity
/// density, fluid.initial_density = "hydrostatic"): samples at rest (v = 0) are binned in columns
/// dp wide along gravity; each contiguous run of a column (a gap over 1.5 dp starts a new one)
/// has its top sample dp / 2 below the surface, and a sample at depth d below that surface has
/// P = rho0 |g| d and the EOS's density. Moving samples, and all without gravity, start at rho0.
std::vector<double> hydrostatic_density(const FluidSamples& fs, const Vec3d& gravity, double dp,
                                        const Eos<double>& eos);
/// The same for a share of the samples (`mine`, any subset of the scene's): `all` calls its sink
/// with every sample of the scene (for_each_fluid_sample), of which only those in the columns of
/// `mine` are kept, so a rank holds its columns, not the scene. Equal, bit for bit, to the
/// whole scene's densities of the same samples.
std::vector<double> hydrostatic_density(const FluidSamples& mine,
                                        const std::function<void(const FluidSampleSink&)>& all,
                                        const Vec3d& gravity, double dp, const Eos<double>& eos);

/// Particle mass that makes an interior particle of a perfect lattice sit at rest density with
/// the chosen kernel (so a fluid at rest starts without a pressure jolt).
double lattice_particle_mass(KernelType kernel, double support, double dp, double rho0);

struct BoundarySamples {
  std::vector<Vec3d> x;
  std::vector<std::uint32_t> obstacle; // index into scene.obstacles, kWallObstacle for walls
  std::vector<double> volume_scale;    // volume / dp^3 (1 unless the lattice is stretched)
};

/// Calls f(x, obstacle, volume_scale) for each boundary particle filling a shell `depth` thick
/// (the kernel support) inside every solid: the domain walls and each obstacle, on the fluid's
/// lattice of spacing dp. The n-th call is particle n (its id).
using BoundarySampleSink =
    std::function<void(const Vec3d& x, std::uint32_t obstacle, double volume_scale)>;
void for_each_boundary_sample(const Scene& scene, double dp, double depth,
                              const BoundarySampleSink& f, SamplerWork* work = nullptr);

/// All of them (for_each_boundary_sample's, in its order).
BoundarySamples sample_boundaries(const Scene& scene, double dp, double depth);

} // namespace kf
