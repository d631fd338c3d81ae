#pragma once
// The knit phase of a simulation: its points and springs, the substeps it runs inside one
// simulation step, its step limit, and its snapshot phase. Owned by SimulationT when the scene
// has the knit module; nothing of it exists otherwise.
#include "comm/HaloExchange.hpp"
#include "domain/KnitBuilder.hpp"
#include "domain/Scene.hpp"
#include "io/Frame.hpp"
#include "kernels/boundary/RigidContact_K.hpp"
#include "kernels/boundary/RigidShape.hpp"
#include "kernels/integrate/Verlet.hpp"
#include "kernels/knit/KnitForces_K.hpp"
#include "kernels/knit/SelfContact.hpp"
#include "kernels/knit/SpringTopology.hpp"
#include "kernels/particles/KnitSet.hpp"

#include <array>
#include <functional>
#include <limits>
#include <optional>

namespace kf {

struct KnitEnergy {
  double kinetic = 0, elastic = 0, potential = 0;
  double contact = 0; // self-contact penalty energy
  double total() const { return kinetic + elastic + potential + contact; }
};

template <typename T>
class KnitSystem {
public:
  /// shared: the knit will be shared out over N ranks (KnitHalo::distribute keeps a rank's
  /// points): no spring is kept (take_rows builds the rank's points' rows once they are known,
  /// and they migrate with the points), the whole mesh's volume cells are kept on the host
  /// (localize gathers a rank's rows from them), the step limit waits for the first choice of
  /// ghosts (set_spring_limits), and the whole knit's self-contact grid and lists are not built
  /// (the halo's first choice sorts the rank's points), so no rank's backend holds the whole
  /// knit's topology, nor its host the whole knit's springs.
  KnitSystem(const Scene& scene, exec::Exec ex, bool shared = false);

  /// Advances the knit by dt from time t in scene.knit.substeps velocity Verlet substeps; keep
  /// is the velocity factor of one substep's half kick (global damping).
  /// set_shapes(t) moves the solids to time t (called before each substep's collisions when
  /// solids move); shapes and n_shapes are the device array it updates.
  /// couple(weight, own, copies), when set, evaluates the forces with those from outside (the
  /// fluid): it sets a = (own + outside) / m + g in one pass (KnitFluidCoupling::add_forces
  /// with own), after gathering the self-contact's copies (own reads them) with its own;
  /// weight is the time over which that a acts (h/2 at the step's ends, h between), so the
  /// partner can take the opposite impulse. With couple set the step starts by evaluating the
  /// forces afresh (the partner has moved since the last).
  using Couple = std::function<void(T, const KnitForceTerms<T>&, const WatchedCopies<T>&)>;
  void advance(double t, double dt, T keep, const std::function<void(double)>& set_shapes,
               const RigidShape<T>* shapes, std::size_t n_shapes, const Couple& couple = {});
  /// The watchdog's measures of the work from outside (domain/Watchdog) in the coming advances:
  /// the moving handles' (knit_handle_work, after each substep's forces) added to *handles, a
  /// double on the backend; the moving solids' contact (ContactWork, its m left to the set's).
  /// Null / no sum: not measured.
  void measure_work(double* handles, ContactWork<T> contact) {
    handle_work_ = handles;
    contact_work_ = contact;
  }
  /// A further bound on the substep (the knit-fluid contact's), applied by stable_dt.
  void set_substep_limit(double sub) { extra_limit_ = sub; }
  /// Largest step (all substeps together) the springs and the contact radius allow now.
  double stable_dt();
  /// stable_dt() from bounds already read (motion_bounds_to, then one read for several sets).
  double stable_dt(const MotionBounds<T>& mb);
  void motion_bounds_to(MotionBounds<T>* out);
  /// How far a point may move in a step of dt, from the speed and acceleration stable_dt() saw
  /// (an estimate; huge before the first stable_dt()).
  double expected_motion(double dt) const { return vmax_ * dt + 0.5 * amax_ * dt * dt; }
  /// a(t) from the springs, self-contact and gravity (the first half kick needs it).
  void compute_forces();

  io::Phase phase() const;
  /// The yarn curves through the stitches' bonding points (snapshot phase "yarn"): position,
  /// yarn index, and segment (point pairs, ParaView draws them as lines); empty when
  /// knit.yarn_samples is 0. With saturation (per knit point) the yarn points carry it too, for
  /// rendering wet yarn (darker, thicker: paper §6.3).
  /// x: every point's position in mesh order (on N ranks, gathered on the writing rank; empty
  /// elsewhere: the fields without rows); the set's by default.
  io::Phase yarn_phase(const std::vector<double>* saturation = nullptr,
                       const std::vector<Vec3<T>>* x = nullptr) const;
  /// Every point's state from a snapshot phase in mesh (id) order; on N ranks the set becomes
  /// the whole knit again, for KnitHalo::distribute.
  void restore(const io::Phase& p);
  /// Restart state of the self-collision grid (snapshot fields and scalars: SimulationT), when
  /// self-collision is on; restore_self_contact after restore().
  std::optional<typename SkinWatch<T>::State> self_contact_state() const {
    if (!self_)
      return std::nullopt;
    return self_->state();
  }
  void restore_self_contact(const typename SkinWatch<T>::State& s) { self_->restore(ex_, set_, s); }

  std::size_t size() const { return set_.size(); }

  /// On N ranks (KnitHalo): the set holds `owned` points, which this rank integrates, then
  /// ghosts (their copies, refreshed by refresh_ghosts after every drift). The springs of the
  /// owned points and their volume cells are gathered on the backend from the rank's rows
  /// (take_rows, migrated with the points: row k the k-th point's), the cells they name from the
  /// whole mesh's table on the host (compacted on the backend), the other ends by local_of_id
  /// (each mesh index's local index); each point's row keeps the mesh's order, so its forces sum
  /// as on one rank. Every partner must be present (KnitHalo checks).
  void localize(const exec::DeviceBuffer<std::uint32_t>& local_of_id, std::size_t owned);
  /// After localize: the owned points' farthest partner (squared) and whether one is absent.
  PartnerReach<T> partner_reach() const;
  /// Points this rank integrates (all on one rank).
  std::size_t owned() const { return std::min(owned_, set_.size()); }
  void set_ghost_refresh(std::function<void()> refresh) { refresh_ghosts_ = std::move(refresh); }
  /// Built to be shared over N ranks.
  bool shared() const { return shared_; }
  /// A shared knit: the springs' and cells' rows of the points ids (mesh indices, the set's
  /// owned points in its order), built from the scene (the mesh built again, only their springs
  /// and cells kept).
  void take_rows(const std::vector<std::uint64_t>& ids);
  /// The rank's rows as migration columns (the springs' and the cells' counts and rows, their
  /// points' ids), for KnitHalo to move with the points.
  std::vector<comm::MigrationColumn> row_columns();
  /// The points the rank's rows are for, in order (the set's owned points after a migration).
  const std::vector<std::uint64_t>& row_ids() const { return row_ids_; }
  /// The rank's spring rows on the host (shared), for `held` figures and tests.
  const typename SpringTopology<T>::HostRows* host_rows() const {
    return rows_ ? &*rows_ : nullptr;
  }
  /// The rank's volume cells' rows on the host (shared), as host_rows.
  const typename VolumeTopology<T>::HostRows* host_cell_rows() const {
    return cell_rows_ ? &*cell_rows_ : nullptr;
  }
  /// The step limits of the owned points' springs and cells at their rest positions (after a
  /// localize that found every partner): the shortest sqrt(m / sum k), m / sum c. On N ranks
  /// the job's minimum is what one rank computes (set_spring_limits).
  std::array<double, 2> owned_spring_limits();
  void set_spring_limits(double spring, double damping);
  bool spring_limits_known() const { return spring_limit_ == spring_limit_; }
  /// The farthest two points of a spring or a volume cell lie apart at rest.
  double rest_reach() const { return rest_reach_; }
  /// The mesh's rest positions in mesh order, host side.
  const std::vector<Vec3<T>>& mesh_rest() const { return mesh_rest_; }
  KnitSelfContact<T>* self_contact() { return self_ ? &*self_ : nullptr; }
  std::size_t bytes() const;
  /// Of bytes(): the springs' and cells' rows, held for owned points only on N ranks.
  std::size_t row_bytes() const { return springs_.bytes() + volumes_.bytes(); }
  std::uint64_t collisions() const { return collisions_.host_value(0); }
  /// stats: also the self-contact's statistics the energy reads (one pass for both).
  KnitEnergy energy(SelfContactStats* stats = nullptr);
  const SpringTopology<T>& springs() const { return springs_; }
  std::size_t volume_cells() const { return volumes_.cells(); }
  KnitSet<T>& set() { return set_; }
  const exec::Exec& exec() const { return ex_; }
  double min_rigid_distance(const RigidShape<T>* shapes, std::size_t n_shapes);
  const std::vector<KnitPieceLayout>& pieces() const { return pieces_; }
  /// The longest rest length of a stretch spring: the widest gap between points of a sheet.
  double longest_spacing() const { return longest_spacing_; }
  /// The lightest point that is not pinned or moved by a handle (1e300 when none).
  double min_free_mass() const;
  /// Self-collision: off when the scene turns it off; stats are those of the latest forces.
  bool self_collision() const { return self_.has_value(); }
  SelfContactStats self_contact_stats();
  const SelfContactParams<T>* self_contact_params() const {
    return self_ ? &self_->params() : nullptr;
  }

private:
  const Scene& scene_;
  exec::Exec ex_;
  KnitSet<T> set_;
  SpringTopology<T> springs_;
  VolumeTopology<T> volumes_;
  // On N ranks, the rank's points' spring rows (take_rows; migrated with them) and the whole
  // mesh's cells' rows that localize() gathers from, on the host; springs_ and volumes_ then
  // hold a rank's points' rows only. Neither backend nor host keeps the mesh's lists past a
  // build.
  bool shared_ = false;
  std::optional<typename SpringTopology<T>::HostRows> rows_;
  std::vector<std::uint64_t> row_ids_;
  std::optional<typename VolumeTopology<T>::HostRows> cell_rows_;
  std::optional<typename VolumeTopology<T>::Cells> mesh_cells_;
  KnitMeshStats mesh_stats_;
  void set_handle_velocities(double t);
  exec::DeviceBuffer<Vec3<T>> handle_v_;
  std::vector<Vec3<T>> handle_v_host_;
  std::vector<KnitPieceLayout> pieces_;
  Vec3<T> gravity_;
  /// The springs', volume cells', gravity's and self-contact's terms for a force pass (the
  /// self-contact's reads its copies: gathered before the pass).
  KnitForceTerms<T> own_terms();
  /// a from the knit's own terms, or with couple's (weight: see advance).
  void internal_forces(const Couple& couple = {}, T weight = T(0));
  void setup_self_contact(const KnitMesh& mesh, double stiffest, bool shared);
  // min sqrt(m / sum k), m / sum c over free points (cached: fixed); NaN on N ranks until the
  // first choice of ghosts sets it.
  double spring_limit_ = std::numeric_limits<double>::quiet_NaN();
  double contact_limit_ = 1e30; // spring_factor sqrt(m_min / (kMaxContacts k_self))
  double extra_limit_ = 1e30;
  // Largest speed and acceleration at the last stable_dt(): the self-contact grid's motion bound
  // for the coming step (infinite before the first: every substep then checks on the host).
  double vmax_ = 1e30, amax_ = 1e30;
  double longest_spacing_ = 0, rest_reach_ = 0;
  std::optional<KnitSelfContact<T>> self_;
  // The mesh's fixed columns, for a restore on N ranks (the set then holds a rank's share).
  std::vector<Vec3<T>> mesh_rest_;
  std::vector<std::uint32_t> mesh_handle_;
  std::vector<std::uint8_t> mesh_layer_;
  std::vector<std::uint16_t> mesh_piece_;
  std::size_t owned_ = std::size_t(-1);
  std::function<void()> refresh_ghosts_;
  /// The set's view over the points this rank integrates.
  KnitView<T> owned_view() {
    auto p = set_.view();
    p.n = owned();
    return p;
  }
  double* handle_work_ = nullptr;
  // The forces on the handles' points at the last force pass, where handles move and their
  // work is measured (own_terms); indexed as the set, written for the handles' points only.
  exec::DeviceBuffer<Vec3<T>> held_force_;
  ContactWork<T> contact_work_{};
  bool handles_move() const;
  // Point-substeps in contact with a solid, whole run; on the device, read for diagnostics only.
  exec::DeviceBuffer<std::uint64_t> collisions_;
};

} // namespace kf
