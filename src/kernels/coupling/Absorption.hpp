#pragma once
// The mass-conserving absorption model's state and stages (kernels in Absorption_K.hpp): the
// knit points' dry and absorbed masses and capacities, the pore links between them, and per
// fluid step: absorb the particles that touch the fabric, let the absorbed fluid move along the
// links (Darcy, explicit substeps below its stability limit), and emit drops from points that
// hold more than they can.
#include "kernels/coupling/Absorption_K.hpp"
#include "kernels/coupling/KnitFluidCoupling.hpp"

#include <array>
#include <vector>

namespace kf {

struct AbsorptionStats {
  std::uint64_t absorbed_particles = 0, emitted_particles = 0; // whole run
  double diffused_mass = 0; // net mass moved along links per fluid step, summed over the run
};

template <typename T>
class ConservingAbsorption {
public:
  /// links: pore links (i, j, conductance) between knit points, each listed once.
  ConservingAbsorption(exec::Backend b, const AbsorptionParams<T>& params,
                       const std::vector<T>& dry_mass, const std::vector<T>& capacity,
                       const std::vector<std::array<std::uint32_t, 2>>& links,
                       const std::vector<double>& conductance);

  /// Absorbs the fluid particles within reach of an unsaturated knit point (removing them from
  /// the fluid, whose grid is then stale); returns how many.
  std::size_t absorb(const exec::Exec& ex, KnitSet<T>& knit, FluidSet<T>& fluid,
                     CellView<T> fluid_cells, KnitFluidCoupling<T>& coupling);
  /// Moves absorbed fluid along the pore links over dt.
  void diffuse(const exec::Exec& ex, KnitSet<T>& knit, double dt);
  /// Emits one drop from every point holding more than emit_saturation of its capacity by a
  /// quarter of it (or a full particle's mass, if less); the drop takes that excess (at most a
  /// particle's mass), appended to the fluid with ids from next_id (advanced); returns how many.
  std::size_t emit(const exec::Exec& ex, KnitSet<T>& knit, FluidSet<T>& fluid,
                   std::uint64_t& next_id);

  const exec::DeviceBuffer<T>& absorbed() const { return absorbed_; }
  const exec::DeviceBuffer<T>& capacity() const { return capacity_; }
  /// Restart: the absorbed masses as written (knit order); the knit's masses follow.
  void restore(const exec::Exec& ex, KnitSet<T>& knit, const std::vector<T>& absorbed);
  double stable_substep() const { return stable_substep_; }
  const AbsorptionStats& stats() const { return stats_; }
  std::size_t bytes() const;

private:
  AbsorptionParams<T> params_;
  exec::DeviceBuffer<T> dry_, absorbed_, capacity_, delta_, s_sorted_;
  exec::DeviceBuffer<std::uint32_t> link_start_, link_other_, target_, keep_, emit_, offsets_;
  exec::DeviceBuffer<T> link_k_, fraction_;
  exec::DeviceBuffer<Vec3<T>> dmom_;
  exec::DeviceBuffer<T> start_; // absorbed at the start of diffuse(), for its stats
  double stable_substep_ = 1e30;
  AbsorptionStats stats_;
};

} // namespace kf
