#pragma once
// The mass-conserving absorption model's state and stages (kernels in Absorption_K.hpp): the
// knit points' dry and absorbed masses and capacities, the pore links between them, and per
// fluid step: absorb the particles that touch the fabric, let the absorbed fluid move along the
// links (Darcy, explicit substeps below its stability limit), and emit drops from points that
// hold more than they can.
#include "kernels/coupling/Absorption_K.hpp"
#include "kernels/coupling/KnitFluidCoupling.hpp"

#include <array>
#include <functional>
#include <vector>

namespace kf {

/// What a job split in space supplies to the absorption (domain/AbsorptionRanks; absent on one
/// rank). The knit holds this rank's points first, then ghosts; the fluid its owned particles
/// and ghosts, flagged. Each transfer is computed once, by the owner of the particle or point
/// that loses or gains, from values the other side holds as a copy: the job conserves mass to
/// rounding as one rank does.
template <typename T>
struct AbsorptionSplit {
  std::size_t knit_owned = 0;
  const std::uint32_t* fluid_owned = nullptr; // 1 owned, 0 ghost, per local fluid particle
  const std::uint32_t* knit_of_id = nullptr;  // knit id -> local index (kNoTarget: not here)
  /// The fluid ghosts' rows of a column from their owners.
  std::function<void(exec::DeviceBuffer<std::uint32_t>&)> fluid_ghost_rows;
  /// The knit ghosts' rows of a column from their owners.
  std::function<void(exec::DeviceBuffer<T>&)> knit_ghost_rows;
  /// The knit ghosts' absorbed mass, mass and velocity from their owners (after a change).
  std::function<void()> knit_ghost_state;
  /// Given this rank's emitting points' ids, returns the job's count of emitters and replaces
  /// each id by its place among the job's emitters in id order (the drop ids' offsets: the
  /// one-rank run numbers its drops in that order).
  std::function<std::uint64_t(std::vector<std::uint64_t>&)> number_drops;
  /// Before drops are appended to the fluid: its ghosts go (they sort anew after).
  std::function<void()> drop_fluid_ghosts;
};

struct AbsorptionStats {
  std::uint64_t absorbed_particles = 0, emitted_particles = 0; // whole run
  double diffused_mass = 0; // net mass moved along links per fluid step, summed over the run
};

/// The Darcy flow's explicit stability limit [s]: 0.5 min_i C_i / (4.5 scale sum_l K_il) (dPhi/dm
/// = -scale J'(s) / C with |J'| <= 4.5 on s <= 1.5, scale = sigma / sqrt(kappa / phi));
/// infinite without links.
double darcy_stable_substep(const std::vector<double>& capacity,
                            const std::vector<std::array<std::uint32_t, 2>>& links,
                            const std::vector<double>& conductance, double pressure_scale);

template <typename T>
class ConservingAbsorption {
public:
  /// links: pore links (i, j, conductance) between knit points, each listed once.
  ConservingAbsorption(exec::Backend b, const AbsorptionParams<T>& params,
                       const std::vector<T>& dry_mass, const std::vector<T>& capacity,
                       const std::vector<std::array<std::uint32_t, 2>>& links,
                       const std::vector<double>& conductance);

  struct Absorbed {
    std::size_t removed = 0; // particles taken whole (removed from the fluid)
    std::size_t partial = 0; // particles that gave part of their mass
  };
  /// Absorbs the fluid particles within reach of an unsaturated knit point. One rank: those
  /// taken whole are removed from the fluid (whose grid is then stale). Split: the owned
  /// particles give, nothing is removed; keep() flags the owned survivors 1 (ghosts 0) for the
  /// caller to remove the rest (RankExchange::remove).
  Absorbed absorb(const exec::Exec& ex, KnitSet<T>& knit, FluidSet<T>& fluid,
                  CellView<T> fluid_cells, KnitFluidCoupling<T>& coupling,
                  const AbsorptionSplit<T>* split = nullptr);
  const exec::DeviceBuffer<std::uint32_t>& keep() const { return keep_; }
  /// Moves absorbed fluid along the pore links over dt.
  void diffuse(const exec::Exec& ex, KnitSet<T>& knit, double dt,
               const AbsorptionSplit<T>* split = nullptr);
  /// Emits one drop from every point holding more than emit_saturation of its capacity by a
  /// quarter of it (or a full particle's mass, if less); the drop takes that excess (at most a
  /// particle's mass), appended to the fluid with ids from next_id (advanced by the job's
  /// count); returns the job's count.
  std::size_t emit(const exec::Exec& ex, KnitSet<T>& knit, FluidSet<T>& fluid,
                   std::uint64_t& next_id, const AbsorptionSplit<T>* split = nullptr);

  /// On N ranks, after the knit's ghosts were chosen (KnitSystem::localize's arguments): the
  /// owned points' links over local indices, each row in the whole knit's order.
  void localize(const std::vector<std::uint64_t>& ids, std::size_t owned);
  /// The per-point columns that travel with a knit point (dry and absorbed mass, capacity).
  std::array<exec::DeviceBuffer<T>*, 3> point_columns() { return {&dry_, &absorbed_, &capacity_}; }

  const exec::DeviceBuffer<T>& absorbed() const { return absorbed_; }
  const exec::DeviceBuffer<T>& capacity() const { return capacity_; }
  PoreMass<T> pores() const { return {absorbed_.data(), capacity_.data()}; }
  /// Restart: the absorbed masses of the whole knit as written (id order; on N ranks before the
  /// points are shared out again); the knit's masses follow.
  void restore(const exec::Exec& ex, KnitSet<T>& knit, const std::vector<T>& absorbed);
  double stable_substep() const { return stable_substep_; }
  const AbsorptionStats& stats() const { return stats_; }
  std::size_t bytes() const;

private:
  AbsorptionParams<T> params_;
  exec::DeviceBuffer<T> dry_, absorbed_, capacity_, delta_, s_sorted_;
  exec::DeviceBuffer<std::uint32_t> link_start_, link_other_, target_, keep_, emit_, offsets_;
  exec::DeviceBuffer<T> link_k_, degree_, fraction_;
  exec::DeviceBuffer<std::uint64_t> drop_id_; // split: each emitter's drop offset
  // The whole knit's links (compressed rows over ids), for localize().
  std::vector<std::uint32_t> mesh_start_, mesh_other_;
  std::vector<T> mesh_k_, mesh_dry_, mesh_capacity_;
  /// The whole knit's columns and links (one rank's layout).
  void whole();
  exec::DeviceBuffer<Vec3<T>> dmom_;
  exec::DeviceBuffer<T> start_; // absorbed at the start of diffuse(), for its stats
  double stable_substep_ = 1e30;
  AbsorptionStats stats_;
};

} // namespace kf
