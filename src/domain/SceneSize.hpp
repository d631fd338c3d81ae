#pragma once
// A scene's size from its numbers alone (P8): how many particles and cells it asks for and the
// memory they take, before anything is sampled or allocated. `plan` and `run` check it first, so
// a scene that cannot fit (a spacing of 1e-5 m: ~1e13 particles) is refused in one line naming
// what it asks for against what the machine has, instead of sampling for hours or dying in
// std::bad_alloc. Counts are doubles: an absurd scene must not overflow its own estimate.
#include "domain/Scene.hpp"
#include "kernels/exec/Backend.hpp"

#include <string>

namespace kf {

struct SceneSize {
  double fluid = 0, boundary = 0, knit = 0; // particles (estimates, within a few percent)
  double cells = 0;                         // the fluid's neighbour grid
  double bytes = 0;                         // the particle sets and grids, all ranks together
  double largest() const;                   // the largest particle count
};

/// The estimate: fluid blocks' lattices, the walls' and obstacles' shells, the knit's three
/// layers of (wales + 1) x (courses + 1) points a piece (mesh pieces: not counted), the grid's
/// cells; bytes at the particle sets' and grids' sizes in the scene's precision.
SceneSize estimate_size(const Scene& scene);

/// Throws InputError when the scene cannot run with `available` bytes for `sharing` ranks (those
/// of the job on one host, or on one GPU): more particles of one kind than 32-bit indices
/// address, or a share of the bytes (bytes / ranks, times `sharing`) above `available`. `where`
/// names the memory ("this machine's memory (MemAvailable)", "the GPU's free memory").
void check_size(const Scene& scene, const SceneSize& size, double available, int ranks, int sharing,
                const std::string& where);

/// The memory a process can have here now: the host's available memory (/proc/meminfo's
/// MemAvailable) or the selected CUDA device's free memory; 0 when it cannot be read.
double available_memory(exec::Backend b);

/// "1.9 PiB", "22.1 GiB": one decimal in the largest unit under 1024 (plan's memory lines too).
std::string format_bytes(double bytes);

} // namespace kf
