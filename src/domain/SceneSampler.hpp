#pragma once
// A scene's fluid or boundary samples as layers of lattices, so that a rank of a split job
// samples a share of the scene, or its own region, and still gives each sample the id the whole
// scene's order gives it. The fluid: each block's lattice (blocks in order), carved by the
// solids; the boundary: the domain's lattice continued into the solids, a shell of `depth`
// inside each (Samplers.hpp says why). A layer is a lattice's points at one z; a sample's id
// counts the samples of the layers before its own, then those before it in its layer (x
// fastest, then y). Host-only and deterministic.
#include "core/Vec3.hpp"
#include "domain/Scene.hpp"

#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <vector>

namespace kf {

struct SamplerWork; // Samplers.hpp

/// One sample: its id, position, and the fluid's velocity or the boundary's solid and volume.
struct Sample {
  std::uint64_t id = 0;
  Vec3d x{}, v{};
  std::uint32_t obstacle = 0; // boundary: the scene's obstacle, kWallObstacle for the walls
  double volume_scale = 1;    // boundary: volume / dp^3
};
using SampleSink = std::function<void(const Sample&)>;

class SceneSampler {
public:
  enum class Kind { Fluid, Boundary };
  /// dp: the lattice's spacing; depth: the boundary's shell (the support radius; unused for the
  /// fluid). `by_points`: every point decided by its own distances, no box bounded (the
  /// reference bench_samplers times; the same samples).
  SceneSampler(const Scene& scene, Kind kind, double dp, double depth, bool by_points = false);
  ~SceneSampler();
  SceneSampler(const SceneSampler&) = delete;
  SceneSampler& operator=(const SceneSampler&) = delete;

  /// Layers of all the lattices, in the samples' order.
  int layers() const;
  /// The samples of layers [first, last), in order, ids counted from `first_id` (the samples
  /// before layer `first`); returns each of those layers' sample count.
  std::vector<std::uint64_t> layer_samples(int first, int last, std::uint64_t first_id,
                                           const SampleSink& f) const;
  /// The samples whose lattice points lie in [lo - margin, hi + margin] (a jittered sample may
  /// lie up to the jitter beside its point), in order, each with its id, given the sample count
  /// of every layer (layer_samples's, over all layers). Reads the points of the box and counts
  /// the rest of its layers by boxes: a region's work, not the scene's.
  void samples_in(const Vec3d& lo, const Vec3d& hi, double margin,
                  std::span<const std::uint64_t> layer_counts, const SampleSink& f) const;
  /// What was done so far: lattice points read, boxes bounded, points tested alone.
  SamplerWork work() const;

private:
  struct Lattices;
  std::unique_ptr<Lattices> l_;
};

} // namespace kf
