#pragma once
// The tunnelling guard (P8 stage 5; docs/ARCHITECTURE.md "Tunnelling guard"): after the fluid's
// drift, a fluid particle whose step crossed a face of the knit's sheet (its front and back
// layers as triangles) goes back to its side, and meets the face inelastically: the knit takes
// the opposite impulse. The fluid-knit contact acts between points, so without it fluid passes
// through the gaps between them at any speed.
#include "kernels/coupling/KnitFluidCoupling.hpp"
#include "kernels/coupling/SheetGuard_K.hpp"

#include <array>
#include <functional>
#include <vector>

namespace kf {

template <typename T>
class SheetGuard {
public:
  /// faces: three knit points (mesh indices) each; offsets and ids: per mesh index its faces
  /// (CSR, offsets of size points + 1). gap: how far from the face a particle put back lands.
  /// The reach of each particle's search comes from the faces at every call (SheetExtent: the
  /// longest edge, the corners' step and their box) and the particle's own step.
  SheetGuard(exec::Backend b, const std::vector<std::array<std::uint32_t, 3>>& faces,
             const std::vector<std::uint32_t>& offsets, const std::vector<std::uint32_t>& ids,
             T gap, T speed_scale);

  /// On N ranks (collective): adds the ghosts' rows of a column of kSheetSumWidth values a knit
  /// point into their owners' rows, then (`back`) copies the owners' rows to their ghosts.
  using GhostSums = std::function<void(exec::DeviceBuffer<std::uint64_t>&, bool back)>;

  /// After the fluid's drift over dt (the knit at the step's end, its ghosts current on N
  /// ranks; knit_x0: its positions at the step's start, the same points): puts back the particles
  /// whose step crossed a face, counting those `counted` flags (null: all) into *count (device
  /// memory), and gives each its reaction: the particle's normal velocity and the knit points'
  /// velocities change (ghost_sums: null on one rank; each sum complete on every rank holding
  /// the point). knit_of_id: mesh
  /// index -> local knit point (null: the identity); coupling: its knit grid finds the points
  /// near a particle (its cells hold each point within three of its watch's skins of where it
  /// is: the walk reaches that much farther).
  void apply(const exec::Exec& ex, FluidView<T> f, T dt, KnitSet<T>& knit,
             const exec::DeviceBuffer<Vec3<T>>& knit_x0, const KnitFluidCoupling<T>& coupling,
             const std::uint32_t* knit_of_id, const std::uint32_t* counted, std::uint64_t* count,
             const GhostSums& ghost_sums = {}) const;

  std::size_t faces() const { return vertex_.size() / 3; }

private:
  exec::DeviceBuffer<std::uint32_t> vertex_, offsets_, ids_;
  mutable exec::DeviceBuffer<T> extent_; // SheetExtent's values at the last call
  // Per fluid particle, where it met the sheet; per knit point, the reaction's sums.
  mutable exec::DeviceBuffer<std::uint32_t> hit_face_;
  mutable exec::DeviceBuffer<Vec3<T>> hit_w_, hit_n_;
  mutable exec::DeviceBuffer<std::uint64_t> sums_;
  T gap_, quantum_;
};

} // namespace kf
