#include "domain/KnitSystem.hpp"

#include "domain/FrameFields.hpp"
#include "domain/StageParts.hpp"
#include "domain/Yarns.hpp"
#include "kernels/boundary/Boundary.hpp"
#include "kernels/integrate/Verlet.hpp"
#include "kernels/knit/Knit.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace kf {

template <typename T>
KnitSystem<T>::KnitSystem(const Scene& scene, exec::Exec ex, bool shared)
    : scene_(scene), ex_(ex), set_(ex.backend), springs_(ex.backend), volumes_(ex.backend),
      handle_v_(ex.backend, 0, "knit.handle_velocity"), gravity_(vec_cast<T>(scene.gravity)),
      held_force_(ex.backend, 0, "knit.held_force"),
      collisions_(ex.backend, 0, "knit.contact_count") {
  collisions_.assign(std::vector<std::uint64_t>{0});
  // Shared: no spring is kept here (take_rows builds a rank's once its points are known).
  const std::vector<std::uint8_t> none;
  KnitMesh mesh = build_knit(scene, shared ? &none : nullptr);
  shared_ = shared;
  const std::size_t n = mesh.x.size();
  std::vector<Vec3<T>> x(n), v(n);
  std::vector<T> m(n);
  std::vector<std::uint64_t> id(n);
  for (std::size_t i = 0; i < n; ++i) {
    x[i] = vec_cast<T>(mesh.x[i]);
    v[i] = vec_cast<T>(mesh.v[i]);
    m[i] = static_cast<T>(mesh.m[i]);
    id[i] = i;
  }
  set_.resize(n);
  set_.x.assign(x);
  set_.x_rest.assign(x);
  set_.v.assign(v);
  set_.a.assign(std::vector<Vec3<T>>(n, Vec3<T>{}));
  set_.m.assign(m);
  set_.handle.assign(mesh.handle);
  set_.layer.assign(mesh.layer);
  set_.piece.assign(mesh.piece);
  set_.id.assign(id);
  mesh_rest_ = x;
  mesh_handle_ = mesh.handle;
  mesh_layer_ = mesh.layer;
  mesh_piece_ = mesh.piece;
  pieces_ = mesh.pieces;
  // What the springs tell beyond their rows (every spring built, kept or not): the widest gap
  // between points of a sheet, the stiffest spring (the self-contact's default), the farthest a
  // spring or volume cell reaches at rest (the split's ghost width).
  const KnitMeshStats& st = mesh.stats;
  longest_spacing_ = st.longest_stretch;
  const double stiffest = st.stiffest;
  rest_reach_ = st.longest;
  mesh_stats_ = st;
  for (const VolumeCell& c : mesh.volumes)
    for (std::uint32_t a : c.point)
      for (std::uint32_t b : c.point)
        rest_reach_ = std::max(rest_reach_, double(norm(x[a] - x[b])));
  set_handle_velocities(0.0);
  if (shared) {
    // The cells' corners and constants whole on the host; the step limit once a rank's rows are
    // localized (set_spring_limits: a minimum over the points, the same on any rank count).
    mesh_cells_.emplace(VolumeTopology<T>::mesh_cells(ex_.backend, mesh.volumes, n));
  } else {
    T spring = 0, damping = 0;
    springs_.build(mesh.springs, n);
    volumes_.build(mesh.volumes, n);
    knit_spring_limits(ex_, set_.view(), springs_.view(), volumes_.view(), spring, damping);
    set_spring_limits(double(spring), double(damping));
  }
  // The lists go once their rows exist (nothing reads them after: a restore on N ranks
  // builds a rank's rows again): 40 bytes a spring, ~11 springs a point, a large knit's most.
  std::vector<Spring>().swap(mesh.springs);
  std::vector<VolumeCell>().swap(mesh.volumes);
  if (scene.knit.self_collision && n > 0)
    setup_self_contact(mesh, stiffest, shared);
}

template <typename T>
void KnitSystem<T>::set_spring_limits(double spring, double damping) {
  spring_limit_ = std::min(spring * scene_.knit.spring_factor, damping);
}

template <typename T>
std::array<double, 2> KnitSystem<T>::owned_spring_limits() {
  // At the rest positions, as one rank's constructor takes them (x_rest travels with the
  // points; the cells' corners among the owned points and ghosts after a choice).
  KnitView<T> p = owned_view();
  p.x = set_.x_rest.data();
  T spring = 0, damping = 0;
  knit_spring_limits(ex_, p, springs_.view(), volumes_.view(), spring, damping);
  return {double(spring), double(damping)};
}

template <typename T>
void KnitSystem<T>::take_rows(const std::vector<std::uint64_t>& ids) {
  const std::size_t n = mesh_rest_.size();
  std::vector<std::uint8_t> mine(n, 0);
  for (const std::uint64_t i : ids)
    mine.at(i) = 1;
  // The build again, keeping this rank's points' springs and cells only (its stats are every
  // spring's and cell's).
  const KnitMesh mesh = build_knit(scene_, &mine, &mine);
  // Every rank's rows as wide as the widest point's: a migration moves rows of one size.
  rows_.emplace(
      SpringTopology<T>::host_rows(ex_.backend, mesh.springs, n, ids, mesh_stats_.widest));
  if (rows_->width != mesh_stats_.widest)
    throw Error("knit springs: a rank's rows are " + std::to_string(rows_->width) +
                " wide, the mesh's widest point has " + std::to_string(mesh_stats_.widest));
  rows_->springs = mesh_stats_.springs;
  rows_->by_kind = mesh_stats_.by_kind;
  cell_rows_.emplace(VolumeTopology<T>::host_rows(ex_.backend, mesh.volumes, mesh.volume_index, n,
                                                  ids, mesh_stats_.widest_cells));
  if (cell_rows_->width != mesh_stats_.widest_cells)
    throw Error("knit volume cells: a rank's rows are " + std::to_string(cell_rows_->width) +
                " wide, the mesh's widest point has " + std::to_string(mesh_stats_.widest_cells));
  row_ids_ = ids;
}

template <typename T>
std::vector<comm::MigrationColumn> KnitSystem<T>::row_columns() {
  if (!rows_)
    throw Error("KnitSystem: no rows to migrate before take_rows");
  auto& r = *rows_;
  auto& c = *cell_rows_;
  return {{sizeof(std::uint32_t),
           [&c](std::size_t k) {
             c.count.resize(k);
             return reinterpret_cast<unsigned char*>(c.count.data());
           }},
          {std::size_t(c.width) * sizeof(std::uint32_t),
           [&c](std::size_t k) {
             c.cell.resize(k * c.width);
             return reinterpret_cast<unsigned char*>(c.cell.data());
           }},
          {sizeof(std::uint32_t),
           [&r](std::size_t k) {
             r.count.resize(k);
             return reinterpret_cast<unsigned char*>(r.count.data());
           }},
          {std::size_t(r.width) * sizeof(SpringEntry<T>),
           [&r](std::size_t k) {
             r.entry.resize(k * r.width);
             return reinterpret_cast<unsigned char*>(r.entry.data());
           }},
          {sizeof(std::uint64_t), [this](std::size_t k) {
             row_ids_.resize(k);
             return reinterpret_cast<unsigned char*>(row_ids_.data());
           }}};
}

template <typename T>
void KnitSystem<T>::setup_self_contact(const KnitMesh& mesh, double stiffest, bool shared) {
  const auto& mat = scene_.knit;
  // Defaults: R half the longest in-plane spacing, so a point cannot slip through the gap between
  // four points of another sheet (that needs 2R > spacing / sqrt 2); k the stiffest spring, so
  // contact resists like the fabric does and the step limit hardly moves.
  SelfContactParams<T> p;
  const double radius = mat.self_radius > 0 ? mat.self_radius : 0.5 * longest_spacing_;
  const double k = mat.self_stiffness > 0 ? mat.self_stiffness : stiffest;
  if (!(radius > 0) || !(k > 0))
    return; // a single point: nothing to collide
  p.radius = static_cast<T>(radius);
  // Points closer than 3R at rest never collide: 3R > 2R keeps the rest state free of contact
  // with margin for in-plane compression.
  p.exclusion2 = static_cast<T>(9 * radius * radius);
  p.k = static_cast<T>(k);
  p.zeta = static_cast<T>(mat.damping_ratio);
  p.friction = static_cast<T>(mat.self_friction >= 0 ? mat.self_friction : mat.friction);
  // Grid over the domain with cells of 2R plus a skin of 0.4R (the grid is sorted again only
  // when a point moved farther than the skin), coarsened so it holds at most kMaxCells.
  const Vec3d lo = scene_.domain.min, hi = scene_.domain.max, ext = hi - lo;
  constexpr double kMaxCells = 4e6;
  const double cell = std::max(2.4 * radius, std::cbrt(ext.x * ext.y * ext.z / kMaxCells));
  // Shared: each rank's grid covers its window (KnitHalo fits it before the first sort), never
  // the room (up to kMaxCells: 48 MB of tables a rank).
  self_.emplace(ex_.backend, NeighbourGrid<T>::cover(lo, hi, cell), p,
                KnitSelfContact<T>::kListCapacity, shared);
  self_->set_masses_vary(scene_.has(Module::Capillary) &&
                         scene_.capillary.model == Scene::AbsorptionModel::Conserving);
  if (!shared) // one rank: allocates everything now, so plan's memory figure is the run's
    self_->sync(ex_, set_);
  double m_min = 1e300;
  for (std::size_t i = 0; i < mesh.m.size(); ++i)
    if (mesh.handle[i] == kFreePoint)
      m_min = std::min(m_min, mesh.m[i]);
  // A point in a fold may touch several points at once; the limit allows kMaxContacts.
  constexpr double kMaxContacts = 6;
  contact_limit_ = mat.spring_factor * std::sqrt(m_min / (kMaxContacts * k));
}

template <typename T>
double KnitSystem<T>::min_free_mass() const {
  const auto m = set_.m.to_host();
  const auto handle = set_.handle.to_host();
  double m_min = 1e300;
  for (std::size_t i = 0; i < m.size(); ++i)
    if (handle[i] == kFreePoint)
      m_min = std::min(m_min, double(m[i]));
  return m_min;
}

template <typename T>
KnitForceTerms<T> KnitSystem<T>::own_terms() {
  KnitForceTerms<T> own{{owned_view(), springs_.view(), volumes_.view(), gravity_}};
  if (self_) {
    own.self = self_->evaluator(set_);
    own.with_self = true;
  }
  if (handle_work_ && handles_move()) { // the forces the handles hold their points against
    held_force_.resize(set_.size());
    own.held = held_force_.data();
  }
  return own;
}

template <typename T>
void KnitSystem<T>::internal_forces(const Couple& couple, T weight) {
  if (couple) {
    stage_parts::Scope part("knit.step: fluid coupling (both sides), with the knit's forces");
    // The self-contact's copies, which its term reads, are gathered in the coupling's pass.
    const WatchedCopies<T> copies = self_ ? self_->update_copies(ex_, set_) : WatchedCopies<T>{};
    couple(weight, own_terms(), copies);
    return;
  }
  stage_parts::Scope part("knit.step: springs, volume cells, gravity, self-contact");
  if (self_)
    self_->update(ex_, set_);
  knit_forces(ex_, owned(), own_terms());
}

template <typename T>
void KnitSystem<T>::localize(const exec::DeviceBuffer<std::uint32_t>& local_of_id,
                             std::size_t owned) {
  if (!rows_)
    throw Error("KnitSystem::localize: the knit was not built to be shared over ranks, or has "
                "not taken its rows");
  springs_.localize(ex_, *rows_, local_of_id.data(), owned);
  volumes_.localize(ex_, *mesh_cells_, *cell_rows_, local_of_id.data(), owned);
  owned_ = owned;
  if (self_)
    self_->set_active(owned);
}

template <typename T>
PartnerReach<T> KnitSystem<T>::partner_reach() const {
  return knit_partner_reach(ex_, owned(), set_.x.data(), springs_.view(), volumes_.view());
}

template <typename T>
SelfContactStats KnitSystem<T>::self_contact_stats() {
  if (!self_)
    return {};
  self_->sync(ex_, set_);
  return self_->stats(ex_, set_);
}

template <typename T>
void KnitSystem<T>::set_handle_velocities(double t) {
  std::vector<Vec3<T>> hv;
  for (const auto& pin : scene_.knit.pins)
    hv.push_back(vec_cast<T>(pin.velocity_at(t)));
  if (hv.empty())
    hv.push_back({}); // never read; keeps the pointer valid
  auto same = [](const Vec3<T>& a, const Vec3<T>& b) {
    return a.x == b.x && a.y == b.y && a.z == b.z;
  };
  if (hv.size() == handle_v_host_.size() &&
      std::equal(hv.begin(), hv.end(), handle_v_host_.begin(), same))
    return; // copied to the device only when a handle starts or stops
  handle_v_host_ = hv;
  handle_v_.assign(hv);
}

template <typename T>
bool KnitSystem<T>::handles_move() const {
  for (const auto& u : handle_v_host_)
    if (u.x != T(0) || u.y != T(0) || u.z != T(0))
      return true;
  return false;
}

template <typename T>
void KnitSystem<T>::compute_forces() {
  internal_forces();
}

template <typename T>
void KnitSystem<T>::advance(double t, double dt, T keep,
                            const std::function<void(double)>& set_shapes,
                            const RigidShape<T>* shapes, std::size_t n_shapes,
                            const Couple& couple) {
  const int n = scene_.knit.substeps;
  const double h = dt / n;
  if (self_) // how far a point may go this step, from the bounds stable_dt() read
    self_->begin_step(ex_, set_, static_cast<T>(expected_motion(dt)));
  if (couple)
    internal_forces(couple, static_cast<T>(0.5 * h));
  const T radius = static_cast<T>(scene_.knit.radius());
  const T friction = static_cast<T>(scene_.knit.friction);
  for (int s = 0; s < n; ++s) {
    auto p = owned_view();
    set_handle_velocities(t + s * h);
    const Prescribed<T> fixed{p.handle, handle_v_.data()};
    ContactWork<T> contact = contact_work_;
    contact.m = p.m;
    {
      // One kernel: the previous substep's closing half kick (a is unchanged since), this
      // substep's half kick and drift, and the contact with solids (kick_drift_contact).
      stage_parts::Scope part("knit.step: kick-drift, contact with solids");
      if (n_shapes && set_shapes)
        set_shapes(t + (s + 1) * h);
      kick_drift_contact(ex_, p.x, p.v, p.a, p.n, static_cast<T>(h), keep, s > 0, fixed, shapes,
                         n_shapes, radius, friction, collisions_.data(), "knit.kick_drift", nullptr,
                         nullptr, contact);
    }
    if (refresh_ghosts_) {
      stage_parts::Scope part("knit.step: ghosts' positions and velocities from their owners");
      refresh_ghosts_();
    }
    internal_forces(couple, static_cast<T>(s + 1 < n ? h : 0.5 * h));
    if (handle_work_ && handles_move()) // these forces act for h: the closing half, the next
      knit_handle_work(ex_, p, held_force_.data(), gravity_, handle_v_.data(), static_cast<T>(h),
                       handle_work_);
    if (s + 1 == n) {
      stage_parts::Scope part("knit.step: kick");
      kick(ex_, p.v, p.a, p.n, static_cast<T>(h), keep, "knit.kick", fixed);
    }
  }
}

template <typename T>
double KnitSystem<T>::stable_dt() {
  auto p = owned_view();
  return stable_dt(motion_bounds(ex_, p.v, p.a, p.n, "knit.dt"));
}

template <typename T>
void KnitSystem<T>::motion_bounds_to(MotionBounds<T>* out) {
  auto p = owned_view();
  kf::motion_bounds_to(ex_, p.v, p.a, p.n, out, "knit.dt");
}

template <typename T>
double KnitSystem<T>::stable_dt(const MotionBounds<T>& mb) {
  const double vmax = std::sqrt(double(mb.v2));
  if (!std::isfinite(vmax) || !std::isfinite(double(mb.a2)))
    throw InstabilityError("a knit velocity or acceleration is not finite");
  vmax_ = vmax;
  amax_ = std::sqrt(double(mb.a2));
  if (!spring_limits_known())
    throw Error("knit on N ranks: the step limit is read before the first choice of ghosts");
  double sub = std::min({spring_limit_, contact_limit_, extra_limit_});
  // A substep moves no point more than half its contact radius, so collisions are not skipped.
  if (vmax > 0)
    sub = std::min(sub, 0.5 * scene_.knit.radius() / vmax);
  return sub * scene_.knit.substeps;
}

template <typename T>
KnitEnergy KnitSystem<T>::energy(SelfContactStats* stats) {
  auto p = owned_view();
  KnitEnergy e;
  e.kinetic = knit_kinetic_energy(ex_, p);
  e.elastic = knit_spring_energy(ex_, p, springs_.view(), volumes_.view());
  e.potential = knit_potential_energy(ex_, p, gravity_);
  const SelfContactStats sc = self_contact_stats();
  e.contact = sc.energy;
  if (stats)
    *stats = sc;
  return e;
}

template <typename T>
double KnitSystem<T>::min_rigid_distance(const RigidShape<T>* shapes, std::size_t n_shapes) {
  return double(kf::min_rigid_distance(ex_, set_.x.data(), owned(), shapes, n_shapes));
}

template <typename T>
io::Phase KnitSystem<T>::phase() const {
  // The owned points (on N ranks the ghosts follow them: their owners write them).
  const std::size_t n = owned();
  const auto own = [n](auto v) {
    v.resize(n);
    return v;
  };
  io::Phase p{"knit", {}};
  p.fields.push_back(io::Field::from("position", flatten(own(set_.x.to_host())), 3));
  p.fields.push_back(io::Field::from("velocity", flatten(own(set_.v.to_host())), 3));
  p.fields.push_back(io::Field::from("acceleration", flatten(own(set_.a.to_host())), 3));
  p.fields.push_back(io::Field::from("rest_position", flatten(own(set_.x_rest.to_host())), 3));
  p.fields.push_back(io::Field::from("mass", own(set_.m.to_host()), 1));
  const auto layer = own(set_.layer.to_host());
  p.fields.push_back(
      io::Field::from("layer", std::vector<std::uint32_t>(layer.begin(), layer.end()), 1));
  p.fields.push_back(io::Field::from("handle", own(set_.handle.to_host()), 1));
  p.fields.push_back(io::Field::from("id", own(set_.id.to_host()), 1));
  return p;
}

template <typename T>
io::Phase KnitSystem<T>::yarn_phase(const std::vector<double>* saturation,
                                    const std::vector<Vec3<T>>* at) const {
  io::Phase p{"yarn", {}};
  if (scene_.knit.yarn_samples < 1)
    return p;
  const auto xt = at ? *at : set_.x.to_host();
  std::vector<Vec3d> x(xt.size());
  for (std::size_t i = 0; i < x.size(); ++i)
    x[i] = vec_cast<double>(xt[i]);
  std::vector<std::vector<YarnPoint>> yarns;
  bool coloured = false;
  // An empty `at` (another rank than the one writing the yarns): the phase's fields, no rows.
  for (std::size_t k = 0; k < pieces_.size(); ++k)
    coloured |= !scene_.knit.pieces[k].colour_chart.empty();
  for (std::size_t k = 0; k < (at && at->empty() ? 0 : pieces_.size()); ++k) {
    const KnitPiece& piece = scene_.knit.pieces[k];
    auto course = yarn_points(x, saturation, pieces_[k], piece.chart);
    for (std::size_t j = 0; j < course.size(); ++j) {
      if (!piece.colour_chart.empty())
        for (YarnPoint& q : course[j])
          if (q.wale >= 0)
            q.colour = stitch_colour(piece.colour_chart, piece.colours, q.wale, int(j));
      yarns.push_back(std::move(course[j]));
    }
  }
  const YarnLines lines = yarn_lines(yarns, scene_.knit.yarn_samples);
  std::vector<Vec3<T>> pos(lines.x.size());
  for (std::size_t i = 0; i < pos.size(); ++i)
    pos[i] = vec_cast<T>(lines.x[i]);
  std::vector<std::uint32_t> seg;
  seg.reserve(2 * lines.segment.size());
  for (const auto& s : lines.segment) {
    seg.push_back(s[0]);
    seg.push_back(s[1]);
  }
  p.fields.push_back(io::Field::from("position", flatten(pos), 3));
  p.fields.push_back(io::Field::from("yarn", lines.yarn, 1));
  p.fields.push_back(io::Field::from("segment", seg, 2));
  if (saturation) {
    std::vector<T> sat(lines.s.begin(), lines.s.end());
    p.fields.push_back(io::Field::from("saturation", sat, 1));
  }
  if (coloured) { // float RGB a point; negative where a piece has no colour chart
    std::vector<float> c;
    c.reserve(3 * lines.colour.size());
    for (const Vec3d& v : lines.colour)
      c.insert(c.end(), {float(v.x), float(v.y), float(v.z)});
    p.fields.push_back(io::Field::from("colour", c, 3));
  }
  return p;
}

template <typename T>
void KnitSystem<T>::restore(const io::Phase& p) {
  const auto x = unflatten(require(p, "position").as<T>());
  const std::size_t n = mesh_rest_.size();
  if (x.size() != n)
    throw Error("restart: the snapshot has " + std::to_string(x.size()) +
                " knit points but the scene builds " + std::to_string(n));
  if (set_.size() != n || owned_ != std::size_t(-1)) { // a rank's share: the whole knit again
    set_.resize(n);
    set_.x_rest.assign(mesh_rest_);
    set_.handle.assign(mesh_handle_);
    set_.layer.assign(mesh_layer_);
    set_.piece.assign(mesh_piece_);
    std::vector<std::uint64_t> id(n);
    std::iota(id.begin(), id.end(), std::uint64_t(0));
    set_.id.assign(id);
    owned_ = std::size_t(-1);
    rows_.reset(); // the rank's rows: distribute takes them again for its points
    cell_rows_.reset();
    row_ids_.clear();
  }
  set_.x.assign(x);
  set_.v.assign(unflatten(require(p, "velocity").as<T>()));
  set_.a.assign(unflatten(require(p, "acceleration").as<T>()));
  set_.m.assign(require(p, "mass").as<T>());
}

template <typename T>
std::size_t KnitSystem<T>::bytes() const {
  // (The mesh's rows on N ranks are the host's.)
  return set_.size() * KnitSet<T>::bytes_per_particle() + springs_.bytes() + volumes_.bytes() +
         (self_ ? self_->bytes() : 0);
}

template class KnitSystem<float>;
template class KnitSystem<double>;

} // namespace kf
