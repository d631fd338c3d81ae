#pragma once
// The knit points of one rank of a job split in space (P5 stage 4; docs/ARCHITECTURE.md, "The
// knit on N ranks"). Between steps a rank holds the knit points in its blocks. Before the
// knit's first step those that left migrate to their blocks' owners, and the points within the
// knit's ghost width of the rank's region arrive as ghosts after the owned ones: every spring
// and volume-cell partner of an owned point (checked, by global id; the width doubles until none
// is missing) and every point its self-contact lists or cell walks can reach, plus a skin. The
// ghosts stay, refreshed (positions, velocities) at each step's start and after every drift,
// until a point may have moved half the skin (the steps' estimated motions summed, then read): then
// migration and the choice run again (like "verlet" lists; a point owned by a rank stays its until
// then). The self-contact grid's reference positions travel with the points, and its motion
// readings are the job's, so it is sorted when the one-rank run sorts it and lists the same
// partners in the same order: the split knit is the one-rank knit bit for bit. The points stay on
// the set's backend: the choices (migration, ghosts, partners) read copies of positions and ids on
// the host and happen only when the ghosts are chosen anew; the refreshes between substeps move
// device rows (RankExchange's copier and transport).
#include "comm/HaloExchange.hpp"
#include "comm/MpiTransport.hpp"
#include "domain/ExchangeColumns.hpp"
#include "domain/KnitSystem.hpp"
#include "domain/RankExchange.hpp"
#include "kernels/coupling/KnitFluidCoupling.hpp"

#include <cstdint>
#include <functional>
#include <optional>
#include <span>
#include <vector>

namespace kf {

template <typename T>
class KnitHalo {
public:
  /// coupling: the knit-fluid coupling, when the scene has it (its knit grid is kept like the
  /// self-contact's: sorted in id order, its reference positions carried with the points).
  /// skin: how far points may move before the ghosts are chosen anew (0: half the base width).
  /// An owned point may be that far outside this rank's region until then.
  /// min_width: a width the ghosts must reach at least (the tunnelling guard's faces).
  KnitHalo(RankExchange<T>& ranks, KnitSystem<T>& knit, KnitFluidCoupling<T>* coupling = nullptr,
           double skin = 0, double min_width = 0);

  /// The ghost width before any step: the longest spring or volume cell at rest, stretched by
  /// half, and the self-contact's reach (lists and cell walks: 3.5 cells) plus its skin.
  /// With the coupling: also the reach of a fluid particle's knit candidates (two of its grid's
  /// cells a side) plus its skin.
  /// At least min_width.
  static double base_width(KnitSystem<T>& knit, const KnitFluidCoupling<T>* coupling = nullptr,
                           double min_width = 0);

  /// At the start (every rank built the whole knit's points, the decomposition is made): keeps
  /// this rank's points and builds their springs' rows (KnitSystem::take_rows), which from then
  /// on migrate with them. The states: the self-contact's and the coupling's reference positions
  /// per point in mesh order and their records (a restart's); empty x0: the positions now.
  void distribute(const typename SkinWatch<T>::State& self_state = {{}, T(0), T(0)},
                  const typename SkinWatch<T>::State& coupling_state = {{}, T(0), T(0)});
  /// Before the knit's step (or a pass that reads partners; collective): the ghosts' positions
  /// and velocities from their owners while the ghosts chosen last still cover every partner
  /// (no point moved half the skin since, `motion` for the coming step included); otherwise
  /// the ghosts are chosen anew (rebuild).
  void begin(double motion);
  /// The ghosts' positions and velocities from their owners (after each drift).
  void refresh();
  /// Between steps (diagnostics; collective): the ghosts chosen last, refreshed (chosen first
  /// when there are none), so that values kept per local point stay valid.
  /// After a re-partition the ghosts chosen last still serve (the points stay with their owners
  /// until the next step's choice), and the values kept per local point (the coupling's
  /// saturation) stay in their places.
  void current() {
    if (!built_)
      begin(0.0);
    else
      refresh();
  }
  /// Ghost values of per-point columns (the set's order) from their owners.
  void refresh(std::span<const comm::Column> columns);
  /// Per-point sums (`width` unsigned 64-bit values a point, the set's order; collective): the
  /// ghosts' rows added into their owners' (wrapping integer sums, exact in any order); `back`:
  /// then the owners' totals copied to their ghosts. Staged through the host.
  void add_to_owners(exec::DeviceBuffer<std::uint64_t>& sums, std::size_t width, bool back);
  /// Ghosts present for the blocks' current owners (chosen when there are none or after a
  /// re-partition; collective), without the motion check of begin().
  void ready() {
    if (!built_ || ranks_.repartitions() != repartitions_seen_)
      begin(0.0);
  }

  /// Per-point state of another stage that travels with the points (migrated, copied to the
  /// ghosts): the conserving absorption's masses. Before distribute(). localized(ids, owned)
  /// follows each choice of ghosts, as KnitSystem::localize does.
  using Localized = std::function<void(const std::vector<std::uint64_t>&, std::size_t)>;
  void carry(std::vector<exec::DeviceBuffer<T>*> columns, Localized localized) {
    carried_ = std::move(columns);
    localized_ = std::move(localized);
  }
  /// Each knit id's local index (kAbsent where the point is neither owned nor a ghost here),
  /// valid from one choice of ghosts to the next.
  static constexpr std::uint32_t kAbsent = kAbsentPoint;
  const exec::DeviceBuffer<std::uint32_t>& local_of_id() const { return local_of_id_; }

  /// The self-contact's state over the owned points (snapshots; collective): reference
  /// positions, the job's recorded motion, the host's bound.
  typename SkinWatch<T>::State self_contact_state() const;
  /// The coupling's knit grid's state over the owned points (snapshots; collective).
  typename SkinWatch<T>::State coupling_state() const;
  std::size_t owned() const { return owned_; }
  /// All knit positions of the job in mesh order on rank 0, none elsewhere (the yarns;
  /// collective).
  std::vector<Vec3<T>> positions_on_root() const;
  /// A value per owned point (the set's order), of every rank, in mesh order on rank 0.
  std::vector<double> values_on_root(const std::vector<double>& owned_values) const;
  double width() const { return width_; }
  /// What the halo holds on the backend beside the set: the id -> local index table.
  std::size_t bytes() const { return local_of_id_.capacity_bytes(); }

private:
  /// A sorted grid's reference positions (parallel to the set) and the job's record of it.
  struct Reference {
    exec::DeviceBuffer<Vec3<T>> x0{exec::Backend::Cpu, 0, "knit.halo.x0"};
    T moved2 = T(0), bound = T(0);
    /// From a restart's state in mesh order, or (empty x0) the positions x now.
    void start(const exec::DeviceBuffer<Vec3<T>>& x, const typename SkinWatch<T>::State& s,
               const char* what);
    /// The grid's state as the steps left it: its first `owned` positions, the job's record.
    void take(const typename SkinWatch<T>::State& s, std::size_t owned,
              const comm::MpiContext& mpi);
    /// The first n positions with the record.
    typename SkinWatch<T>::State state(std::size_t n) const;
  };
  /// The state a snapshot writes: the grid's over the owned points while ghosts are held
  /// (`kept`), else the carried reference's.
  typename SkinWatch<T>::State
  carried(const Reference& ref, const std::optional<typename SkinWatch<T>::State>& kept) const;
  /// row(i, out): `width` values of owned point i; returns width values a mesh point, in mesh
  /// order, on rank 0 (collective; empty elsewhere).
  std::vector<double> gather_on_root(int width,
                                     const std::function<void(std::size_t, double*)>& row) const;
  /// The set and the carried references to n points.
  void resize(std::size_t n);
  /// The grids' references the points carry: the self-contact's and the coupling's where the
  /// knit has them (an absent one holds nothing).
  std::vector<Reference*> references() {
    std::vector<Reference*> r;
    if (knit_.self_contact())
      r.push_back(&self_ref_);
    if (coupling_)
      r.push_back(&coupling_ref_);
    return r;
  }
  /// The ghosts' positions and velocities from their owners (untimed).
  void exchange_motion();
  /// Every column a point carries (the set's and the grids' reference positions).
  ExchangeColumns state();
  /// The owned points' rows localized for the points here, and whether every partner of an
  /// owned point is among them (collective); reach_ becomes the farthest partner. When all are,
  /// the localized callback has run.
  bool localize_and_check();
  /// Migration to the blocks' owners (the springs' and cells' rows with their points), the ghosts
  /// chosen and received (every partner present), the springs localized, the self-contact grid
  /// sorted for its reference positions.
  void rebuild();

  RankExchange<T>& ranks_;
  KnitSystem<T>& knit_;
  KnitFluidCoupling<T>* coupling_ = nullptr;
  // The self-contact's and the coupling's knit grids, carried with the points.
  Reference self_ref_, coupling_ref_; // on the set's backend
  double base_width_ = 0, width_ = 0, reach_ = 0, skin_ = 0;
  bool built_ = false;           // ghosts present (chosen for the positions x_built_)
  double travelled_ = 0;         // a bound on any point's motion since then (the job's)
  std::vector<Vec3<T>> x_built_; // the owned points' positions when the ghosts were chosen
  std::size_t owned_ = 0, mesh_points_ = 0;
  std::uint64_t repartitions_seen_ = 0;
  std::optional<comm::HaloExchange> halo_;
  exec::DeviceBuffer<std::uint32_t> local_of_id_;
  comm::MpiTransport host_transport_; // the rows' migration (host memory)
  std::vector<exec::DeviceBuffer<T>*> carried_;
  Localized localized_;
};

} // namespace kf
