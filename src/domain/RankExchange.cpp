#include "domain/RankExchange.hpp"

#include "core/Error.hpp"
#include "domain/GhostSelection.hpp"

#include <algorithm>
#include <cstring>

namespace kf {

namespace {

template <typename U>
std::vector<U> pick(const std::vector<U>& v, const std::vector<std::uint32_t>& idx) {
  std::vector<U> out(idx.size());
  for (std::size_t k = 0; k < idx.size(); ++k)
    out[k] = v[idx[k]];
  return out;
}

template <typename U>
std::vector<unsigned char> to_bytes(const std::vector<U>& v) {
  std::vector<unsigned char> b(v.size() * sizeof(U));
  if (!b.empty())
    std::memcpy(b.data(), v.data(), b.size());
  return b;
}

template <typename U>
std::vector<U> from_bytes(const std::vector<unsigned char>& b) {
  std::vector<U> v(b.size() / sizeof(U));
  if (!b.empty())
    std::memcpy(v.data(), b.data(), b.size());
  return v;
}

template <typename U>
comm::Column column(std::vector<U>& v) {
  return {v.data(), sizeof(U)};
}

template <typename U>
comm::Column column(exec::DeviceBuffer<U>& b) {
  return {b.data(), sizeof(U)};
}

std::vector<std::uint32_t> inverse(const std::vector<std::uint32_t>& perm) {
  std::vector<std::uint32_t> inv(perm.size());
  for (std::size_t k = 0; k < perm.size(); ++k)
    inv[perm[k]] = static_cast<std::uint32_t>(k);
  return inv;
}

} // namespace

template <typename T>
RankExchange<T>::RankExchange(const comm::MpiContext& mpi, const Scene& scene,
                              exec::Backend backend)
    : mpi_(mpi), scene_(scene) {
  const auto refuse = [&](const std::string& what) {
    throw Error("on " + std::to_string(mpi.size()) +
                " ranks knitflow runs fluid and static boundaries so far (the knit, moving solids, "
                "\"verlet\" lists and the GPU join in later stages of P5); this run has " +
                what + ": run it on one rank");
  };
  if (scene.has(Module::Knit))
    refuse("knit");
  for (const auto& o : scene.obstacles)
    if (o.velocity.x != 0 || o.velocity.y != 0 || o.velocity.z != 0)
      refuse("a moving obstacle ('" + o.name + "')");
  if (scene.solver.neighbour_list == Scene::Solver::NeighbourLists::Verlet)
    refuse("solver.neighbour_list = \"verlet\"");
  if (backend != exec::Backend::Cpu)
    refuse("the GPU backend");
  transport_ = comm::make_transport(mpi, comm::TransportKind::Mpi, comm::MemorySpace::Host);
  fluid_width_ = scene.support_radius();
  boundary_width_ = scene.support_radius();
}

template <typename T>
void RankExchange<T>::distribute(FluidSet<T>* fluid, BoundarySet<T>* boundary) {
  const int me = rank();
  std::vector<Vec3<T>> fx, bx;
  if (fluid)
    fx = fluid->x.to_host();
  if (boundary)
    bx = boundary->x.to_host();
  // Blocks over the domain, widened to every particle (walls' particles lie outside it).
  Vec3d lo = scene_.domain.min, hi = scene_.domain.max;
  for (const auto* set : {&fx, &bx})
    for (const auto& q : *set)
      for (int d = 0; d < 3; ++d) {
        (&lo.x)[d] = std::min((&lo.x)[d], double((&q.x)[d]));
        (&hi.x)[d] = std::max((&hi.x)[d], double((&q.x)[d]));
      }
  const BlockGrid grid(lo, hi, scene_.parallel.block_cells * scene_.support_radius());
  std::vector<std::array<double, kPhases>> counts(grid.count(), {0, 0, 0});
  for (const auto& q : fx)
    counts[grid.block_of(vec_cast<double>(q))][static_cast<int>(Phase::Fluid)] += 1;
  for (const auto& q : bx)
    counts[grid.block_of(vec_cast<double>(q))][static_cast<int>(Phase::Boundary)] += 1;
  decomposition_.emplace(
      Decomposition::partition(grid, counts, PhaseCosts{}, ranks(), fluid_width_));
  // A particle moves less than a support radius a step (CFL): the blocks next to this rank's.
  migration_peers_ = neighbour_ranks(*decomposition_, me, grid.edge());

  if (fluid) {
    std::vector<std::uint32_t> mine;
    for (std::size_t i = 0; i < fx.size(); ++i)
      if (decomposition_->owner(vec_cast<double>(fx[i])) == me)
        mine.push_back(static_cast<std::uint32_t>(i));
    const auto v = fluid->v.to_host(), a = fluid->a.to_host();
    const auto m = fluid->m.to_host(), rho = fluid->rho.to_host(), p = fluid->p.to_host();
    const auto drho = fluid->drho.to_host(), drho_prev = fluid->drho_prev.to_host();
    const auto id = fluid->id.to_host();
    fluid->resize(mine.size());
    fluid->x.assign(pick(fx, mine));
    fluid->v.assign(pick(v, mine));
    fluid->a.assign(pick(a, mine));
    fluid->m.assign(pick(m, mine));
    fluid->rho.assign(pick(rho, mine));
    fluid->p.assign(pick(p, mine));
    fluid->drho.assign(pick(drho, mine));
    fluid->drho_prev.assign(pick(drho_prev, mine));
    fluid->id.assign(pick(id, mine));
    fluid_owned_ = mine.size();
    fluid_owned_flag_.assign(mine.size(), 1);
  }
  if (boundary) {
    std::vector<std::uint32_t> mine;
    for (std::size_t i = 0; i < bx.size(); ++i)
      if (decomposition_->owner(vec_cast<double>(bx[i])) == me)
        mine.push_back(static_cast<std::uint32_t>(i));
    auto x = pick(bx, mine), x0 = pick(boundary->x0.to_host(), mine);
    auto obstacle = pick(boundary->obstacle.to_host(), mine);
    auto volume = pick(boundary->volume.to_host(), mine);
    auto id = pick(boundary->id.to_host(), mine);
    std::vector<Vec3d> xd(x.size());
    for (std::size_t i = 0; i < x.size(); ++i)
      xd[i] = vec_cast<double>(x[i]);
    // The ghosts come from their owners (not from this rank's copy of the scene), so their
    // order is the one the owners' refreshes will send in.
    const GhostLists gl = select_ghosts(*decomposition_, me, xd, boundary_width_);
    boundary_halo_.emplace(*transport_, gl.peers, gl.send);
    const std::size_t n = mine.size(), total = n + boundary_halo_->received();
    for (auto* v : {&x, &x0})
      v->resize(total);
    obstacle.resize(total);
    volume.resize(total);
    id.resize(total);
    const comm::Column cols[] = {column(x), column(x0), column(obstacle), column(volume),
                                 column(id)};
    boundary_halo_->exchange(cols, n);
    boundary->resize(total);
    boundary->x.assign(x);
    boundary->x0.assign(x0);
    boundary->obstacle.assign(obstacle);
    boundary->volume.assign(volume);
    boundary->id.assign(id);
    boundary_own_count_ = n;
    boundary_owned_.assign(total, 0);
    std::fill(boundary_owned_.begin(), boundary_owned_.begin() + n, 1);
  }
}

template <typename T>
void RankExchange<T>::boundary_sorted(const std::vector<std::uint32_t>& perm) {
  if (!boundary_halo_)
    return;
  boundary_halo_->remap(inverse(perm), boundary_own_count_);
  boundary_owned_ = pick(boundary_owned_, perm);
}

template <typename T>
typename RankExchange<T>::Removed RankExchange<T>::rebuild(FluidSet<T>& fluid, const Vec3<T>& lo,
                                                           const Vec3<T>& hi,
                                                           const std::array<bool, 6>& walls) {
  const int me = rank();
  const std::size_t n = fluid.size();
  auto x = fluid.x.to_host();
  // Fluid past an open side leaves the job (the single-rank sort removes it the same way).
  Removed gone;
  std::vector<int> dest(n);
  const auto m_host = fluid.m.to_host();
  for (std::size_t i = 0; i < n; ++i) {
    bool out = false;
    for (int d = 0; d < 3; ++d) {
      const T c = (&x[i].x)[d];
      out = out || (!walls[2 * d] && c < (&lo.x)[d]) || (!walls[2 * d + 1] && c > (&hi.x)[d]);
    }
    if (out) {
      dest[i] = -1;
      ++gone.particles;
      gone.mass += double(m_host[i]);
    } else {
      dest[i] = decomposition_->owner(vec_cast<double>(x[i]));
    }
  }
  // The removed are kept out by sending them nowhere: compact first.
  std::vector<std::uint32_t> kept;
  for (std::size_t i = 0; i < n; ++i)
    if (dest[i] >= 0)
      kept.push_back(static_cast<std::uint32_t>(i));
  std::vector<int> kept_dest(kept.size());
  for (std::size_t k = 0; k < kept.size(); ++k)
    kept_dest[k] = dest[kept[k]];
  std::vector<unsigned char> bx = to_bytes(pick(x, kept)),
                             bv = to_bytes(pick(fluid.v.to_host(), kept)),
                             bm = to_bytes(pick(m_host, kept)),
                             brho = to_bytes(pick(fluid.rho.to_host(), kept)),
                             bp = to_bytes(pick(fluid.p.to_host(), kept)),
                             bd = to_bytes(pick(fluid.drho.to_host(), kept)),
                             bdp = to_bytes(pick(fluid.drho_prev.to_host(), kept)),
                             bid = to_bytes(pick(fluid.id.to_host(), kept));
  const comm::ByteColumn state[] = {{&bx, sizeof(Vec3<T>)}, {&bv, sizeof(Vec3<T>)},
                                    {&bm, sizeof(T)},       {&brho, sizeof(T)},
                                    {&bp, sizeof(T)},       {&bd, sizeof(T)},
                                    {&bdp, sizeof(T)},      {&bid, sizeof(std::uint64_t)}};
  const std::size_t owned = comm::migrate(*transport_, migration_peers_, kept_dest, state);
  auto ox = from_bytes<Vec3<T>>(bx), ov = from_bytes<Vec3<T>>(bv);
  auto om = from_bytes<T>(bm), orho = from_bytes<T>(brho), op = from_bytes<T>(bp);
  auto od = from_bytes<T>(bd), odp = from_bytes<T>(bdp);
  auto oid = from_bytes<std::uint64_t>(bid);
  // The ghosts: every owned particle within the support of another rank's region goes there.
  std::vector<Vec3d> xd(owned);
  for (std::size_t i = 0; i < owned; ++i)
    xd[i] = vec_cast<double>(ox[i]);
  const GhostLists gl = select_ghosts(*decomposition_, me, xd, fluid_width_);
  fluid_halo_.emplace(*transport_, gl.peers, gl.send);
  const std::size_t total = owned + fluid_halo_->received();
  ox.resize(total);
  ov.resize(total);
  for (auto* v : {&om, &orho, &op, &od, &odp})
    v->resize(total);
  oid.resize(total);
  const comm::Column cols[] = {column(ox), column(ov), column(om),  column(orho),
                               column(op), column(od), column(odp), column(oid)};
  fluid_halo_->exchange(cols, owned);
  fluid.resize(total);
  fluid.x.assign(ox);
  fluid.v.assign(ov);
  fluid.m.assign(om);
  fluid.rho.assign(orho);
  fluid.p.assign(op);
  fluid.drho.assign(od);
  fluid.drho_prev.assign(odp);
  fluid.id.assign(oid);
  fluid_owned_ = owned;
  fluid_owned_flag_.assign(total, 0);
  std::fill(fluid_owned_flag_.begin(), fluid_owned_flag_.begin() + owned, 1);
  return gone;
}

template <typename T>
void RankExchange<T>::fluid_sorted(const std::vector<std::uint32_t>& perm) {
  if (!fluid_halo_)
    return;
  fluid_halo_->remap(inverse(perm), fluid_owned_);
  fluid_owned_flag_ = pick(fluid_owned_flag_, perm);
}

template <typename T>
void RankExchange<T>::refresh_density(FluidSet<T>& fluid) {
  if (!fluid_halo_)
    return;
  const comm::Column cols[] = {column(fluid.rho), column(fluid.p), column(fluid.vp),
                               column(fluid.vol)};
  fluid_halo_->exchange(cols, fluid_owned_);
}

template <typename T>
void RankExchange<T>::refresh_boundary(BoundarySet<T>& boundary) {
  if (!boundary_halo_)
    return;
  const comm::Column cols[] = {column(boundary.p), column(boundary.vp), column(boundary.inv_rho)};
  boundary_halo_->exchange(cols, boundary_own_count_);
}

template <typename T>
void RankExchange<T>::drop_ghosts(const exec::Exec& ex, FluidSet<T>& fluid) {
  if (fluid.size() == fluid_owned_)
    return;
  exec::DeviceBuffer<std::uint32_t> keep(ex.backend, 0, "ranks.owned");
  keep.assign(std::vector<std::uint32_t>(fluid_owned_flag_.begin(), fluid_owned_flag_.end()));
  fluid.keep_flagged(ex, keep);
  fluid_owned_flag_.assign(fluid.size(), 1);
  fluid_halo_.reset();
}

template class RankExchange<float>;
template class RankExchange<double>;

} // namespace kf
