#include "domain/KnitHalo.hpp"

#include "core/Error.hpp"
#include "domain/ExchangeColumns.hpp"
#include "domain/GhostSelection.hpp"
#include "domain/StageParts.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numeric>

namespace kf {

template <typename T>
KnitHalo<T>::KnitHalo(RankExchange<T>& ranks, KnitSystem<T>& knit, KnitFluidCoupling<T>* coupling,
                      double skin, double min_width)
    : ranks_(ranks), knit_(knit), coupling_(coupling), mesh_points_(knit.size()),
      local_of_id_(knit.set().x.backend(), 0, "knit.halo.local"), host_transport_(ranks.mpi()) {
  const exec::Backend b = knit.set().x.backend();
  self_ref_.x0 = exec::DeviceBuffer<Vec3<T>>(b, 0, "knit.halo.self_x0");
  coupling_ref_.x0 = exec::DeviceBuffer<Vec3<T>>(b, 0, "knit.halo.coupling_x0");
  if (!knit.shared())
    throw Error("KnitHalo: the knit was not built to be shared over ranks (KnitSystem's shared)");
  base_width_ = base_width(knit, coupling, min_width);
  skin_ = skin > 0 ? skin : 0.5 * base_width_;
  const comm::MpiContext& mpi = ranks_.mpi();
  const auto job_max = [&mpi](T m2) { return static_cast<T>(mpi.max(double(m2))); };
  if (auto* self = knit.self_contact())
    self->distribute(job_max);
  if (coupling)
    coupling->distribute(job_max);
  knit.set_ghost_refresh([this] { refresh(); });
}

template <typename T>
double KnitHalo<T>::base_width(KnitSystem<T>& knit, const KnitFluidCoupling<T>* coupling,
                               double min_width) {
  const double reach = knit.rest_reach();
  double w = 1.5 * reach;
  if (auto* self = knit.self_contact()) // a row's list reaches a cell; a cell walk 2 cells a side
    w = std::max(w, 3.5 * double(self->cell()) + 2 * double(self->skin()));
  if (coupling)
    w = std::max(w, 3.5 * double(coupling->cell()) + 2 * double(coupling->skin()));
  return std::max(w, min_width);
}

template <typename T>
ExchangeColumns KnitHalo<T>::state() {
  auto& s = knit_.set();
  auto c = ExchangeColumns::of(s.x, s.v, s.a, s.x_rest, s.m, s.handle, s.layer, s.piece, s.id);
  for (Reference* r : references())
    c.add(r->x0);
  for (auto* b : carried_)
    c.add(*b);
  return c;
}

template <typename T>
void KnitHalo<T>::distribute(const typename SkinWatch<T>::State& self_state,
                             const typename SkinWatch<T>::State& coupling_state) {
  const auto timed = ranks_.time_exchange();
  auto& set = knit_.set();
  if (knit_.self_contact())
    self_ref_.start(set.x, self_state, "self-contact");
  if (coupling_)
    coupling_ref_.start(set.x, coupling_state, "coupling");
  auto columns = state();
  owned_ =
      comm::migrate(ranks_.transport(), {}, ranks_.owners(HostValues<Vec3<T>>(set.x).span(), true),
                    columns.migration, ranks_.rows());
  // The whole knit's room freed: the rank keeps its share (its ghosts grow it snugly).
  set.resize(owned_);
  set.shrink_to_fit();
  for (Reference* r : references())
    r->x0.shrink_to_fit();
  for (auto* b : carried_) // (the migration left them owned_ long)
    b->shrink_to_fit();
  // The springs' and cells' rows of the points kept (the set's order), built here: no rank's
  // host builds the whole knit's; from now on they travel with their points (rebuild).
  knit_.take_rows(set.id.to_host());
  repartitions_seen_ = ranks_.repartitions();
  halo_.reset();
  built_ = false;
}

template <typename T>
bool KnitHalo<T>::localize_and_check() {
  const std::vector<std::uint64_t> ids = knit_.set().id.to_host();
  std::vector<std::uint32_t> local(mesh_points_, kAbsent);
  for (std::size_t k = 0; k < ids.size(); ++k)
    local[ids[k]] = static_cast<std::uint32_t>(k);
  local_of_id_.assign(local);
  knit_.localize(local_of_id_, owned_);
  // On the backend, from the rows the force pass reads (a host walk of the mesh's rows cost ~4
  // ms a choice on the 2-core VM for the pour's 25k points a rank: 1.2M partners met, 0.45M
  // distinct). The farthest by its squared distance: one root a choice.
  const PartnerReach<T> r = knit_.partner_reach();
  double both[2] = {double(std::sqrt(r.d2)), double(r.missing)};
  MPI_Allreduce(MPI_IN_PLACE, both, 2, MPI_DOUBLE, MPI_MAX, ranks_.mpi().comm());
  reach_ = both[0];
  if (both[1] != 0)
    return false;
  if (!knit_.spring_limits_known()) { // the job's minimum: one rank's over every point
    auto l = knit_.owned_spring_limits();
    MPI_Allreduce(MPI_IN_PLACE, l.data(), 2, MPI_DOUBLE, MPI_MIN, ranks_.mpi().comm());
    knit_.set_spring_limits(l[0], l[1]);
  }
  if (localized_)
    localized_(ids, owned_);
  return true;
}

template <typename T>
void KnitHalo<T>::begin(double motion) {
  const auto timed = ranks_.time_exchange();
  auto& set = knit_.set();
  // The coming step's motion, twice the estimate (from the job's speed and acceleration bounds,
  // the same on every rank), as SkinWatch allows for one.
  const double ahead = 2 * motion;
  if (built_ && ranks_.repartitions() == repartitions_seen_) {
    // The ghosts last while no point can have moved half the skin since they were chosen: a
    // partner within reach then was within reach + skin of this rank's region. The estimates
    // summed since the choice decide without a reading while they stay inside; past that the
    // positions are read (a copy to the host and a reduction: the knit's one wait a step).
    if (travelled_ + ahead <= 0.5 * skin_) {
      travelled_ += ahead;
      exchange_motion();
      return;
    }
    double moved = 0;
    const HostValues<Vec3<T>> x(set.x, owned_);
    for (std::size_t i = 0; i < owned_; ++i)
      moved = std::max(moved, double(norm(x[i] - x_built_[i])));
    moved = ranks_.mpi().max(std::isnan(moved) ? 1e300 : moved);
    if (moved + ahead <= 0.5 * skin_) {
      travelled_ = moved + ahead;
      exchange_motion();
      return;
    }
  }
  if (built_) {
    // The grids' reference positions as the steps left them (a sort resets them), and the
    // job's records, travel with the points.
    if (const auto st = knit_.self_contact_state())
      self_ref_.take(*st, owned_, ranks_.mpi());
    if (coupling_)
      coupling_ref_.take(coupling_->state(), owned_, ranks_.mpi());
    resize(owned_);
  }
  rebuild();
  travelled_ = ahead;
}

template <typename T>
void KnitHalo<T>::rebuild() {
  stage_parts::Scope part("knit ghosts chosen anew (migration, choice, topology, grids)");
  auto& set = knit_.set();
  const Decomposition& d = ranks_.decomposition();
  // The points that left this rank's blocks go to their owners: the blocks next to this rank's,
  // or anyone after a re-partition.
  std::vector<int> peers = ranks_.migration_peers();
  if (ranks_.repartitions() != repartitions_seen_) {
    peers = ranks_.other_ranks();
    repartitions_seen_ = ranks_.repartitions();
  }
  auto columns = state();
  const std::vector<int> destination = ranks_.owners(HostValues<Vec3<T>>(set.x, owned_).span());
  owned_ = comm::migrate(ranks_.transport(), peers, destination, columns.migration, ranks_.rows());
  set.resize(owned_);
  { // The springs' and cells' rows go with their points, on the host (the same destinations, so
    // the same order: the stayers closed up in order, the arrivals by sending rank in its order).
    auto rows = knit_.row_columns();
    const std::size_t n = comm::migrate(host_transport_, peers, destination, rows);
    const HostValues<std::uint64_t> id(set.id, owned_);
    const auto& row_ids = knit_.row_ids();
    if (n != owned_ || row_ids.size() != owned_ ||
        !std::equal(id.span().begin(), id.span().end(), row_ids.begin()))
      throw Error("knit on N ranks: the springs' and cells' rows parted from their points in a "
                  "migration (" +
                  std::to_string(row_ids.size()) + " rows, " + std::to_string(owned_) + " points)");
  }
  // The ghosts: the width covers the partners as stretched at the last choice (the check below
  // widens it where a spring stretched further) plus the skin the points may move until the
  // next choice.
  double width = std::max(base_width_, 1.25 * reach_) + skin_;
  const BlockGrid& g = d.grid();
  const double most = 4 * g.edge() * (g.nx() + g.ny() + g.nz()) + base_width_;
  { // (a copy: the set grows below)
    const HostValues<Vec3<T>> x(set.x, owned_);
    x_built_.assign(x.span().begin(), x.span().end());
  }
  for (;;) {
    // On the backend, as the fluid's (a host loop over the points cost 7-24 ms a choice on 2
    // GPUs, for the pour's 27k points a rank).
    auto gl = ranks_.ghost_rows(set.x, owned_, width);
    halo_.emplace(ranks_.transport(), std::move(gl.peers), std::move(gl.send), ranks_.rows());
    resize(owned_ + halo_->received());
    const auto received = state();
    halo_->exchange(received.halo, owned_);
    if (localize_and_check())
      break;
    if (width > most)
      throw Error("knit on N ranks: a spring or volume cell spans more than the domain; the "
                  "knit has come apart");
    width *= 2; // a spring stretched past the width: wider, until every partner arrives
    resize(owned_);
  }
  width_ = width;
  built_ = true;
  if (auto* self = knit_.self_contact()) {
    // Its grid over this rank's region and the ghosts' reach, not the room (a point that
    // strays past it until the next choice clamps to an edge cell: still exact).
    const GridGeometry<T>& w = self->whole_grid();
    const auto [lo, hi] = d.window(ranks_.rank(), vec_cast<double>(w.origin), double(w.cell),
                                   {w.nx, w.ny, w.nz}, width + skin_);
    self->fit_window(lo, hi);
    knit_.restore_self_contact(self_ref_.state(set.size()));
  }
  if (coupling_) {
    coupling_->restore(knit_.exec(), set, coupling_ref_.state(set.size()));
    coupling_->set_active(owned_);
  }
}

template <typename T>
void KnitHalo<T>::resize(std::size_t n) {
  knit_.set().resize(n);
  for (Reference* r : references())
    r->x0.resize_snug(n);
  for (auto* b : carried_)
    b->resize_snug(n);
}

template <typename T>
void KnitHalo<T>::exchange_motion() {
  auto& s = knit_.set();
  const comm::Column cols[] = {column(s.x), column(s.v)};
  halo_->exchange(cols, owned_);
}

template <typename T>
void KnitHalo<T>::refresh() {
  if (!halo_)
    return;
  const auto timed = ranks_.time_exchange();
  exchange_motion();
}

template <typename T>
void KnitHalo<T>::refresh(std::span<const comm::Column> columns) {
  if (!halo_)
    return;
  const auto timed = ranks_.time_exchange();
  halo_->exchange(columns, owned_);
}

template <typename T>
void KnitHalo<T>::add_to_owners(exec::DeviceBuffer<std::uint64_t>& sums, std::size_t width,
                                bool back) {
  if (!halo_)
    return;
  const auto timed = ranks_.time_exchange();
  std::vector<std::uint64_t> host = sums.to_host();
  halo_->add_to_owners(host, width, owned_);
  sums.assign(host);
  if (back) {
    const comm::Column c[] = {{sums.data(), width * sizeof(std::uint64_t)}};
    halo_->exchange(c, owned_);
  }
}

template <typename T>
typename SkinWatch<T>::State
KnitHalo<T>::carried(const Reference& ref,
                     const std::optional<typename SkinWatch<T>::State>& kept) const {
  if (!built_ || !kept)
    return ref.state(owned_);
  return {std::vector<Vec3<T>>(kept->x0.begin(), kept->x0.begin() + owned_),
          static_cast<T>(ranks_.mpi().max(double(kept->moved2))), kept->bound};
}

template <typename T>
typename SkinWatch<T>::State KnitHalo<T>::coupling_state() const {
  return carried(coupling_ref_, coupling_ ? std::optional(coupling_->state()) : std::nullopt);
}

template <typename T>
typename SkinWatch<T>::State KnitHalo<T>::self_contact_state() const {
  return carried(self_ref_, knit_.self_contact_state());
}

template <typename T>
void KnitHalo<T>::Reference::start(const exec::DeviceBuffer<Vec3<T>>& x,
                                   const typename SkinWatch<T>::State& s, const char* what) {
  const std::size_t n = x.size();
  x0.resize(n);
  if (s.x0.empty()) {
    x0.copy_from(x, n);
  } else {
    if (s.x0.size() != n)
      throw Error("knit on N ranks: " + std::to_string(s.x0.size()) + " " + what +
                  " reference positions for " + std::to_string(n) + " points");
    x0.assign(s.x0);
  }
  moved2 = s.moved2;
  bound = s.bound;
}

template <typename T>
void KnitHalo<T>::Reference::take(const typename SkinWatch<T>::State& s, std::size_t owned,
                                  const comm::MpiContext& mpi) {
  if (owned)
    exec::copy_bytes(x0.data(), x0.backend(), s.x0.data(), exec::Backend::Cpu,
                     owned * sizeof(Vec3<T>));
  moved2 = static_cast<T>(mpi.max(double(s.moved2)));
  bound = s.bound;
}

template <typename T>
typename SkinWatch<T>::State KnitHalo<T>::Reference::state(std::size_t n) const {
  const auto all = x0.to_host();
  return {{all.begin(), all.begin() + std::min(n, all.size())}, moved2, bound};
}

template <typename T>
std::vector<double>
KnitHalo<T>::gather_on_root(int width, const std::function<void(std::size_t, double*)>& row) const {
  // Each owned point's id and its `width` values, from every rank, placed by id on rank 0.
  const HostValues<std::uint64_t> id(knit_.set().id, owned_);
  const std::size_t w = std::size_t(width) + 1;
  std::vector<double> mine(w * owned_);
  for (std::size_t i = 0; i < owned_; ++i) {
    mine[w * i] = double(id[i]);
    row(i, &mine[w * i + 1]);
  }
  const bool root = ranks_.rank() == 0;
  const int size = ranks_.ranks();
  int n = static_cast<int>(mine.size());
  std::vector<int> counts(root ? size : 0), displs(root ? size : 0);
  MPI_Gather(&n, 1, MPI_INT, counts.data(), 1, MPI_INT, 0, ranks_.mpi().comm());
  if (root)
    std::exclusive_scan(counts.begin(), counts.end(), displs.begin(), 0);
  std::vector<double> all(std::accumulate(counts.begin(), counts.end(), std::size_t(0)));
  MPI_Gatherv(mine.data(), n, MPI_DOUBLE, all.data(), counts.data(), displs.data(), MPI_DOUBLE, 0,
              ranks_.mpi().comm());
  std::vector<double> out(root ? std::size_t(width) * mesh_points_ : 0, 0.0);
  for (std::size_t k = 0; k + w <= all.size(); k += w)
    std::copy_n(&all[k + 1], width, &out[std::size_t(width) * std::size_t(all[k])]);
  return out;
}

template <typename T>
std::vector<Vec3<T>> KnitHalo<T>::positions_on_root() const {
  const HostValues<Vec3<T>> x(knit_.set().x, owned_);
  const auto all = gather_on_root(3, [&x](std::size_t i, double* r) {
    r[0] = double(x[i].x), r[1] = double(x[i].y), r[2] = double(x[i].z);
  });
  std::vector<Vec3<T>> out(all.size() / 3);
  for (std::size_t k = 0; k < out.size(); ++k) // doubles hold T exactly
    out[k] = {static_cast<T>(all[3 * k]), static_cast<T>(all[3 * k + 1]),
              static_cast<T>(all[3 * k + 2])};
  return out;
}

template <typename T>
std::vector<double> KnitHalo<T>::values_on_root(const std::vector<double>& values) const {
  return gather_on_root(1, [&values](std::size_t i, double* r) { r[0] = values.at(i); });
}

template class KnitHalo<float>;
template class KnitHalo<double>;

} // namespace kf
