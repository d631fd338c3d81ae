#include "domain/KnitHalo.hpp"

#include "core/Error.hpp"
#include "domain/ExchangeColumns.hpp"
#include "domain/GhostSelection.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numeric>

namespace kf {

namespace {

/// Adds the seconds of its scope to the split's exchange time.
template <typename T>
struct Timed {
  RankExchange<T>& ranks;
  std::chrono::steady_clock::time_point t0 = std::chrono::steady_clock::now();
  ~Timed() {
    ranks.add_exchange_seconds(
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  }
};

} // namespace

template <typename T>
KnitHalo<T>::KnitHalo(RankExchange<T>& ranks, KnitSystem<T>& knit, KnitFluidCoupling<T>* coupling,
                      double skin)
    : ranks_(ranks), knit_(knit), coupling_(coupling), mesh_points_(knit.size()) {
  // Each point's partners: the other ends of its springs and the other points of its cells.
  std::vector<std::vector<std::uint32_t>> rows(mesh_points_);
  for (const Spring& sp : knit.mesh_springs()) {
    rows[sp.i].push_back(sp.j);
    rows[sp.j].push_back(sp.i);
  }
  for (const VolumeCell& c : knit.mesh_cells())
    for (std::uint32_t a : c.point)
      for (std::uint32_t b : c.point)
        if (a != b)
          rows[a].push_back(b);
  partner_start_.assign(1, 0);
  for (auto& r : rows) {
    std::sort(r.begin(), r.end());
    r.erase(std::unique(r.begin(), r.end()), r.end());
    partner_.insert(partner_.end(), r.begin(), r.end());
    partner_start_.push_back(static_cast<std::uint32_t>(partner_.size()));
  }
  base_width_ = base_width(knit, coupling);
  skin_ = skin > 0 ? skin : 0.5 * base_width_;
  const comm::MpiContext& mpi = ranks_.mpi();
  if (auto* self = knit.self_contact())
    self->distribute(&by_id_, [&mpi](T m2) { return static_cast<T>(mpi.max(double(m2))); });
  if (coupling)
    coupling->distribute(&by_id_, [&mpi](T m2) { return static_cast<T>(mpi.max(double(m2))); });
  knit.set_ghost_refresh([this] { refresh(); });
}

template <typename T>
double KnitHalo<T>::base_width(KnitSystem<T>& knit, const KnitFluidCoupling<T>* coupling) {
  double reach = 0;
  const auto x = knit.set().x_rest.to_host();
  for (const Spring& sp : knit.mesh_springs())
    reach = std::max(reach, sp.rest);
  for (const VolumeCell& c : knit.mesh_cells())
    for (std::uint32_t a : c.point)
      for (std::uint32_t b : c.point)
        reach = std::max(reach, double(norm(x[a] - x[b])));
  double w = 1.5 * reach;
  if (auto* self = knit.self_contact()) // a row's list reaches a cell; a cell walk 2 cells a side
    w = std::max(w, 3.5 * double(self->cell()) + 2 * double(self->skin()));
  if (coupling)
    w = std::max(w, 3.5 * double(coupling->cell()) + 2 * double(coupling->skin()));
  return w;
}

template <typename T>
ExchangeColumns KnitHalo<T>::state() {
  auto& s = knit_.set();
  return ExchangeColumns::of(s.x, s.v, s.a, s.x_rest, s.m, s.handle, s.layer, s.piece, s.id, x0_,
                             cx0_);
}

template <typename T>
void KnitHalo<T>::distribute(const std::vector<Vec3<T>>& x0, T moved2, T bound,
                             const typename SkinWatch<T>::State& coupling_state) {
  const Timed<T> timed{ranks_};
  auto& set = knit_.set();
  const std::size_t n = set.size();
  if (!x0.empty() && x0.size() != n)
    throw Error("knit on N ranks: " + std::to_string(x0.size()) +
                " self-contact reference positions for " + std::to_string(n) + " points");
  x0_.resize(n);
  if (x0.empty())
    x0_.copy_from(set.x, n);
  else
    x0_.assign(x0);
  moved2_ = moved2;
  bound_ = bound;
  cx0_.resize(n);
  if (coupling_state.x0.empty()) {
    cx0_.copy_from(set.x, n);
  } else {
    if (coupling_state.x0.size() != n)
      throw Error("knit on N ranks: " + std::to_string(coupling_state.x0.size()) +
                  " coupling reference positions for " + std::to_string(n) + " points");
    cx0_.assign(coupling_state.x0);
  }
  cmoved2_ = coupling_state.moved2;
  cbound_ = coupling_state.bound;
  const int me = ranks_.rank();
  std::vector<int> dest(n);
  for (std::size_t i = 0; i < n; ++i)
    dest[i] = ranks_.decomposition().owner(vec_cast<double>(set.x.data()[i])) == me ? me : -1;
  auto columns = state();
  owned_ = comm::migrate(ranks_.transport(), {}, dest, columns.migration);
  set.resize(owned_);
  repartitions_seen_ = ranks_.repartitions();
  halo_.reset();
  built_ = false;
}

template <typename T>
bool KnitHalo<T>::partners_present() {
  const auto& set = knit_.set();
  const std::uint64_t* id = set.id.data();
  const Vec3<T>* x = set.x.data();
  local_.assign(mesh_points_, -1);
  for (std::size_t k = 0; k < set.size(); ++k)
    local_[id[k]] = static_cast<std::int64_t>(k);
  double reach = 0, missing = 0;
  for (std::size_t i = 0; i < owned_; ++i)
    for (std::uint32_t e = partner_start_[id[i]]; e < partner_start_[id[i] + 1]; ++e) {
      const std::int64_t l = local_[partner_[e]];
      if (l < 0)
        missing = 1;
      else
        reach = std::max(reach, double(norm(x[l] - x[i])));
    }
  double both[2] = {reach, missing};
  MPI_Allreduce(MPI_IN_PLACE, both, 2, MPI_DOUBLE, MPI_MAX, ranks_.mpi().comm());
  reach_ = both[0];
  return both[1] == 0;
}

template <typename T>
void KnitHalo<T>::begin(double motion) {
  const Timed<T> timed{ranks_};
  auto& set = knit_.set();
  if (built_ && ranks_.repartitions() == repartitions_seen_) {
    // The ghosts last while no point can have moved half the skin since they were chosen: a
    // partner within reach then was within reach + skin of this rank's region.
    double moved = 0;
    for (std::size_t i = 0; i < owned_; ++i)
      moved = std::max(moved, double(norm(set.x.data()[i] - x_built_[i])));
    moved = ranks_.mpi().max(std::isnan(moved) ? 1e300 : moved);
    if (moved + motion <= 0.5 * skin_) {
      const comm::Column cols[] = {column(set.x), column(set.v)};
      halo_->exchange(cols, owned_);
      return;
    }
  }
  if (built_) {
    // The self-contact's reference positions as the steps left them (a sort resets them), and
    // the job's record, travel with the points.
    if (const auto st = knit_.self_contact_state()) {
      std::copy(st->x0.begin(), st->x0.begin() + owned_, x0_.data());
      moved2_ = static_cast<T>(ranks_.mpi().max(double(st->moved2)));
      bound_ = st->bound;
    }
    if (coupling_) {
      const auto st = coupling_->state();
      std::copy(st.x0.begin(), st.x0.begin() + owned_, cx0_.data());
      cmoved2_ = static_cast<T>(ranks_.mpi().max(double(st.moved2)));
      cbound_ = st.bound;
    }
    set.resize(owned_);
    x0_.resize(owned_);
    cx0_.resize(owned_);
  }
  rebuild();
}

template <typename T>
void KnitHalo<T>::rebuild() {
  auto& set = knit_.set();
  const Decomposition& d = ranks_.decomposition();
  const int me = ranks_.rank();
  // The points that left this rank's blocks go to their owners: the blocks next to this rank's,
  // or anyone after a re-partition.
  std::vector<int> peers = ranks_.migration_peers();
  if (ranks_.repartitions() != repartitions_seen_) {
    peers.clear();
    for (int r = 0; r < ranks_.ranks(); ++r)
      if (r != me)
        peers.push_back(r);
    repartitions_seen_ = ranks_.repartitions();
  }
  std::vector<int> dest(owned_);
  for (std::size_t i = 0; i < owned_; ++i)
    dest[i] = d.owner(vec_cast<double>(set.x.data()[i]));
  auto columns = state();
  owned_ = comm::migrate(ranks_.transport(), peers, dest, columns.migration);
  set.resize(owned_);
  // The ghosts: the width covers the partners as stretched at the last choice (the check below
  // widens it where a spring stretched further) plus the skin the points may move until the
  // next choice.
  double width = std::max(base_width_, 1.25 * reach_) + skin_;
  const BlockGrid& g = d.grid();
  const double most = 4 * g.edge() * (g.nx() + g.ny() + g.nz()) + base_width_;
  for (;;) {
    std::vector<Vec3d> xd(owned_);
    for (std::size_t i = 0; i < owned_; ++i)
      xd[i] = vec_cast<double>(set.x.data()[i]);
    const GhostLists gl = select_ghosts(d, me, xd, width);
    halo_.emplace(ranks_.transport(), gl.peers, gl.send);
    const std::size_t total = owned_ + halo_->received();
    set.resize(total);
    x0_.resize(total);
    cx0_.resize(total);
    const auto received = state();
    halo_->exchange(received.halo, owned_);
    if (partners_present())
      break;
    if (width > most)
      throw Error("knit on N ranks: a spring or volume cell spans more than the domain; the "
                  "knit has come apart");
    width *= 2; // a spring stretched past the width: wider, until every partner arrives
    set.resize(owned_);
    x0_.resize(owned_);
    cx0_.resize(owned_);
  }
  width_ = width;
  ++rebuilds_;
  x_built_.assign(set.x.data(), set.x.data() + owned_);
  built_ = true;
  const std::vector<std::uint64_t> ids(set.id.data(), set.id.data() + set.size());
  std::vector<std::uint32_t> order(ids.size());
  std::iota(order.begin(), order.end(), 0u);
  std::sort(order.begin(), order.end(), [&](auto a, auto b) { return ids[a] < ids[b]; });
  by_id_.assign(order);
  knit_.localize(ids, owned_);
  if (knit_.self_collision())
    knit_.restore_self_contact({x0_host_all(), moved2_, bound_});
  if (coupling_) {
    coupling_->restore(exec::Exec{exec::Backend::Cpu}, set, {cx0_.to_host(), cmoved2_, cbound_});
    coupling_->set_active(owned_);
  }
}

template <typename T>
void KnitHalo<T>::refresh() {
  if (!halo_)
    return;
  const Timed<T> timed{ranks_};
  auto& s = knit_.set();
  const comm::Column cols[] = {column(s.x), column(s.v)};
  halo_->exchange(cols, owned_);
}

template <typename T>
void KnitHalo<T>::refresh(std::span<const comm::Column> columns) {
  if (!halo_)
    return;
  const Timed<T> timed{ranks_};
  halo_->exchange(columns, owned_);
}

template <typename T>
typename SkinWatch<T>::State KnitHalo<T>::coupling_state() const {
  if (!built_) {
    const auto all = cx0_.to_host();
    return {{all.begin(), all.begin() + std::min(owned_, all.size())}, cmoved2_, cbound_};
  }
  const auto st = coupling_->state();
  return {std::vector<Vec3<T>>(st.x0.begin(), st.x0.begin() + owned_),
          static_cast<T>(ranks_.mpi().max(double(st.moved2))), st.bound};
}

template <typename T>
typename SkinWatch<T>::State KnitHalo<T>::self_contact_state() const {
  if (!built_)
    return {x0_host(), moved2_, bound_};
  const auto st = knit_.self_contact_state();
  return {std::vector<Vec3<T>>(st->x0.begin(), st->x0.begin() + owned_),
          static_cast<T>(ranks_.mpi().max(double(st->moved2))), st->bound};
}

template <typename T>
std::vector<Vec3<T>> KnitHalo<T>::x0_host() const {
  const auto all = x0_.to_host();
  return {all.begin(), all.begin() + std::min(owned_, all.size())};
}

template <typename T>
std::vector<Vec3<T>> KnitHalo<T>::x0_host_all() const {
  return x0_.to_host();
}

template <typename T>
std::vector<double>
KnitHalo<T>::gather_by_id(int width, const std::function<void(std::size_t, double*)>& row) const {
  // Each owned point's id and its `width` values, from every rank, placed by id.
  const auto& set = knit_.set();
  const std::size_t w = std::size_t(width) + 1;
  std::vector<double> mine(w * owned_);
  for (std::size_t i = 0; i < owned_; ++i) {
    mine[w * i] = double(set.id.data()[i]);
    row(i, &mine[w * i + 1]);
  }
  const int size = ranks_.ranks();
  int n = static_cast<int>(mine.size());
  std::vector<int> counts(size), displs(size);
  MPI_Allgather(&n, 1, MPI_INT, counts.data(), 1, MPI_INT, ranks_.mpi().comm());
  std::exclusive_scan(counts.begin(), counts.end(), displs.begin(), 0);
  std::vector<double> all(std::accumulate(counts.begin(), counts.end(), std::size_t(0)));
  MPI_Allgatherv(mine.data(), n, MPI_DOUBLE, all.data(), counts.data(), displs.data(), MPI_DOUBLE,
                 ranks_.mpi().comm());
  std::vector<double> out(std::size_t(width) * mesh_points_, 0.0);
  for (std::size_t k = 0; k + w <= all.size(); k += w)
    std::copy_n(&all[k + 1], width, &out[std::size_t(width) * std::size_t(all[k])]);
  return out;
}

template <typename T>
std::vector<Vec3<T>> KnitHalo<T>::gather_positions() const {
  const Vec3<T>* x = knit_.set().x.data();
  const auto all = gather_by_id(3, [x](std::size_t i, double* r) {
    r[0] = double(x[i].x), r[1] = double(x[i].y), r[2] = double(x[i].z);
  });
  std::vector<Vec3<T>> out(mesh_points_);
  for (std::size_t k = 0; k < mesh_points_; ++k) // doubles hold T exactly
    out[k] = {static_cast<T>(all[3 * k]), static_cast<T>(all[3 * k + 1]),
              static_cast<T>(all[3 * k + 2])};
  return out;
}

template <typename T>
std::vector<double> KnitHalo<T>::gather_values(const std::vector<double>& values) const {
  return gather_by_id(1, [&values](std::size_t i, double* r) { r[0] = values.at(i); });
}

template class KnitHalo<float>;
template class KnitHalo<double>;

} // namespace kf
