#include "domain/RankExchange.hpp"

#include "core/Error.hpp"
#include "domain/ExchangeColumns.hpp"
#include "domain/GhostSelection.hpp"
#include "domain/StageParts.hpp"
#include "kernels/exec/RowCopy.hpp"
#include "kernels/grid/RankSelection.hpp"

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <string_view>

namespace kf {

namespace {

/// out[k] = v[idx[k]].
template <typename U>
std::vector<U> pick(const std::vector<U>& v, std::span<const std::uint32_t> idx) {
  std::vector<U> out(idx.size());
  for (std::size_t k = 0; k < idx.size(); ++k)
    out[k] = v[idx[k]];
  return out;
}

/// The fluid's state as migration moves it (a too where the forces pass has not yet rewritten
/// it).
template <typename T>
std::vector<comm::MigrationColumn> fluid_state(FluidSet<T>& f, bool acceleration) {
  std::vector<comm::MigrationColumn> c{resizable(f.x),         resizable(f.v), resizable(f.m),
                                       resizable(f.rho),       resizable(f.p), resizable(f.drho),
                                       resizable(f.drho_prev), resizable(f.id)};
  if (acceleration)
    c.push_back(resizable(f.a));
  return c;
}

template <typename T>
std::vector<comm::MigrationColumn> boundary_state(BoundarySet<T>& b) {
  return {resizable(b.x), resizable(b.x0), resizable(b.obstacle), resizable(b.volume),
          resizable(b.id)};
}

} // namespace

template <typename T>
RankExchange<T>::RankExchange(const comm::MpiContext& mpi, const Scene& scene,
                              exec::Backend backend, const SplitInputs& split)
    : mpi_(mpi), backend_(backend), scene_(scene), select_(backend),
      keep_(backend, 0, "ranks.owned"), inverse_(backend, 0, "ranks.inverse"),
      alive_(backend, 0, "ranks.alive") {
  for (auto& c : clocks_)
    c = std::make_unique<exec::Stopwatch>(backend);
  for (SplitRows* r : {&fluid_split_}) {
    r->border = exec::DeviceBuffer<std::uint32_t>(backend, 0, "ranks.border");
    r->interior = exec::DeviceBuffer<std::uint32_t>(backend, 0, "ranks.interior");
    r->flags = exec::DeviceBuffer<std::uint32_t>(backend, 0, "ranks.interior_flags");
    r->scratch = exec::DeviceBuffer<std::uint32_t>(backend, 0, "ranks.interior_scan");
    r->sent = exec::DeviceBuffer<std::uint32_t>(backend, 0, "ranks.sent");
  }
  ghost_list_ = exec::DeviceBuffer<std::uint32_t>(backend, 0, "ranks.ghost_rows");
  boundary_owned_flags_ = exec::DeviceBuffer<std::uint32_t>(backend, 0, "ranks.boundary_owned");
  keeps_ghosts_ = scene.solver.neighbour_list == Scene::Solver::NeighbourLists::Verlet &&
                  scene.has(Module::Fluid);
  overlap_ = scene.parallel.overlap;
  // NCCL between device buffers where every rank has a GPU of its own (auto), CUDA IPC where
  // ranks of one node share GPUs, else MPI through page-locked host memory.
  const auto kind = [&] {
    switch (scene.parallel.transport) {
    case Scene::Parallel::Transport::Mpi:
      return comm::TransportKind::Mpi;
    case Scene::Parallel::Transport::Nccl:
      return comm::TransportKind::Nccl;
    case Scene::Parallel::Transport::Ipc:
      return comm::TransportKind::Ipc;
    case Scene::Parallel::Transport::Auto:
      break;
    }
    return comm::TransportKind::Auto;
  }();
  transport_ = comm::make_transport(mpi, kind,
                                    backend == exec::Backend::Cpu ? comm::MemorySpace::Host
                                                                  : comm::MemorySpace::Device);
  rows_ = make_rows(backend, transport_->memory_space() == comm::MemorySpace::Device);
  // Between device buffers (NCCL) a message is short beside what splitting a pass costs (a
  // second launch; the border's, small, leaves most of the GPU idle at its tail): only the
  // density's refresh, the largest message, before the longest wait, keeps the overlap; the
  // forces' pass (a: one column) runs whole, then exchanges. On two H200s this took 58 us off
  // the 4M-a-GPU dam break's step (docs/PERFORMANCE.md, P9).
  overlap_short_ = overlap_ && transport_->memory_space() == comm::MemorySpace::Host;
  // The border's pass (a tenth of a rank's rows at 1M: under one wave) lasts as long as its
  // longest rows' walk, ~30 us on an H200 whatever its size, and the exchange starts after it:
  // where a rank has its GPU to itself the interior runs beside it on a stream of its own
  // instead of after it. Ranks sharing a GPU fill it with each other's work: there it did not
  // pay (8 ranks of the 8M dam break on one H200, 4% slower a step; docs/PERFORMANCE.md).
  // KF_SIDE_STREAM=1 or 0 chooses either way, for measuring.
  const char* side = std::getenv("KF_SIDE_STREAM");
  const std::string_view forced = side ? side : "";
  if (overlap_ && backend != exec::Backend::Cpu) {
    const bool own = comm::gpus_of_their_own(mpi); // collective: every rank asks
    if (forced == "1" || (forced != "0" && own))
      side_ = std::make_unique<exec::SideStream>(backend);
  }
  costs_ = initial_costs(scene);
  // The widths and the blocks as `knitflow plan` takes them (RankLayout).
  widths_ = halo_widths(scene, split);
}

template <typename T>
void RankExchange<T>::distribute(FluidSet<T>* fluid, BoundarySet<T>* boundary,
                                 std::span<const Vec3<T>> knit, std::uint64_t step) {
  settle_forces();
  last_check_step_ = step;
  std::vector<Vec3<T>> fx, bx;
  if (fluid)
    fx = fluid->x.to_host();
  if (boundary)
    bx = boundary->x.to_host();
  take_partition(first_partition<T>(scene_, widths_, costs(), ranks(), fx, bx, knit));
  // Each rank keeps what it owns: a migration to nobody (destination -1 drops a particle).
  if (fluid) {
    auto state = fluid_state(*fluid, true);
    fluid->resize(comm::migrate(*transport_, {}, owners(fx, true), state, rows()));
    fluid_owned_ = fluid->size();
    all_owned();
  }
  if (boundary) {
    auto state = boundary_state(*boundary);
    boundary->resize(comm::migrate(*transport_, {}, owners(bx, true), state, rows()));
    receive_boundary_ghosts(*boundary, boundary->size());
  }
}

template <typename T>
void RankExchange<T>::adopt(Decomposition d, FluidSet<T>* fluid, BoundarySet<T>* boundary,
                            std::uint64_t step) {
  settle_forces();
  last_check_step_ = step;
  take_partition(std::move(d));
  if (fluid) {
    fluid_owned_ = fluid->size();
    all_owned();
  }
  if (boundary)
    receive_boundary_ghosts(*boundary, boundary->size());
}

template <typename T>
void RankExchange<T>::take_partition(Decomposition d) {
  decomposition_.emplace(std::move(d));
  select_.set(*decomposition_, rank());
  // A particle moves less than a support radius a step (CFL): the blocks next to this rank's.
  migration_peers_ = neighbour_ranks(*decomposition_, rank(), decomposition_->grid().edge());
}

template <typename T>
void RankExchange<T>::boundary_moved(BoundarySet<T>& boundary) {
  settle_forces();
  const Timed timed{exchange_seconds_}, part{parts_.migration};
  migrate_boundary(boundary, false);
}

template <typename T>
const std::uint32_t* RankExchange<T>::boundary_owned_flags() {
  if (!boundary_flags_uploaded_) { // a re-partition reads them twice: counts, then departures
    std::vector<std::uint32_t> flags(boundary_owned_.begin(), boundary_owned_.end());
    boundary_owned_flags_.assign(flags);
    boundary_flags_uploaded_ = true;
  }
  return boundary_owned_flags_.data();
}

template <typename T>
void RankExchange<T>::migrate_boundary(BoundarySet<T>& boundary, bool to_everyone) {
  // The owned boundary goes to its blocks' owners, chosen on the backend; the ghosts are
  // dropped (without a message) and received anew. Every wall closed: none leaves the domain
  // (the volume stands in for the mass the departures count of those that would).
  auto leaving =
      select_.departures(boundary.x, boundary.volume, boundary.size(), Vec3<T>{}, Vec3<T>{},
                         {true, true, true, true, true, true}, boundary_owned_flags());
  if (!to_everyone) {
    // To the neighbours, or to anyone where a solid moved more than a block in a step: read
    // from the leavers' destinations (the job's verdict, every rank taking the same peers).
    int far = 0;
    for (const int to : leaving.leaving.to)
      if (to >= 0 && to != rank() &&
          std::find(migration_peers_.begin(), migration_peers_.end(), to) ==
              migration_peers_.end()) {
        far = 1;
        break;
      }
    MPI_Allreduce(MPI_IN_PLACE, &far, 1, MPI_INT, MPI_MAX, mpi_.comm());
    to_everyone = far != 0;
  }
  auto state = boundary_state(boundary);
  const std::size_t n = comm::migrate(*transport_, to_everyone ? other_ranks() : migration_peers_,
                                      leaving.leaving, state, rows());
  boundary.resize(n);
  receive_boundary_ghosts(boundary, n);
}

template <typename T>
void RankExchange<T>::receive_boundary_ghosts(BoundarySet<T>& boundary, std::size_t n) {
  settle_forces();
  // The ghosts come from their owners (not from this rank's copy of the scene), so their order
  // is the one the owners' refreshes will send in.
  auto gl = select_.ghost_rows(boundary.x, n, widths_.boundary, rows());
  boundary_halo_.emplace(*transport_, std::move(gl.peers), std::move(gl.send), rows());
  const std::size_t total = n + boundary_halo_->received();
  boundary.resize(total);
  const comm::Column cols[] = {column(boundary.x), column(boundary.x0), column(boundary.obstacle),
                               column(boundary.volume), column(boundary.id)};
  boundary_halo_->exchange(cols, n);
  boundary_own_count_ = n;
  boundary_owned_.assign(total, 0);
  std::fill(boundary_owned_.begin(), boundary_owned_.begin() + n, 1);
  boundary_flags_uploaded_ = false;
}

template <typename T>
typename RankExchange<T>::Balance
RankExchange<T>::balance(std::uint64_t step, FluidSet<T>* fluid, BoundarySet<T>* boundary,
                         const exec::DeviceBuffer<Vec3<T>>* knit_x, std::size_t knit_owned,
                         const exec::DeviceBuffer<std::uint32_t>* knit_pairs) {
  Balance b;
  // At the first sort of each window of check_every steps after the one the run started in
  // (with lists kept over steps the sorts come when the fluid has moved, not every step).
  if (!balance_due(step))
    return b;
  settle_forces();
  // The steps since the last check (at least one: balance_due saw a later window).
  const std::uint64_t steps_since = step - last_check_step_;
  last_check_step_ = step;
  const Timed part{parts_.rebalance};
  for (int p = 0; p < kPhases; ++p) {
    const double s = clocks_[p]->collect();
    compute_seconds_ += s;
    phase_seconds_[p] += s;
  }
  const double most = mpi_.max(compute_seconds_), mean = mpi_.sum(compute_seconds_) / ranks();
  compute_seconds_ = 0;
  const double own_knit_seconds = phase_seconds_[static_cast<int>(Phase::Knit)];
  std::array<double, kPhases> seconds = phase_seconds_, slowest = phase_seconds_;
  phase_seconds_ = {};
  MPI_Allreduce(MPI_IN_PLACE, seconds.data(), kPhases, MPI_DOUBLE, MPI_SUM, mpi_.comm());
  MPI_Allreduce(MPI_IN_PLACE, slowest.data(), kPhases, MPI_DOUBLE, MPI_MAX, mpi_.comm());
  // The coupling's pairs beside the knit points, one sample a rank a check (PairCostFit): the
  // knit seconds a step since the last check, the points and the pairs listed for them now.
  // Gathered wherever the knit is (every rank alike), a rank without the pairs of its set as it
  // is sending -1: the pairs weigh only where every rank has them.
  std::optional<HostValues<std::uint32_t>> pairs;
  bool pairs_everywhere = false;
  if (knit_x) {
    double listed = -1;
    if (knit_pairs && knit_pairs->size() >= knit_owned) {
      pairs.emplace(*knit_pairs, knit_owned);
      listed = 0;
      for (std::size_t i = 0; i < knit_owned; ++i)
        listed += (*pairs)[i];
    }
    const double sample[3] = {own_knit_seconds / double(steps_since), double(knit_owned), listed};
    std::vector<double> all(3 * std::size_t(ranks()));
    MPI_Allgather(sample, 3, MPI_DOUBLE, all.data(), 3, MPI_DOUBLE, mpi_.comm());
    pairs_everywhere = true;
    for (int r = 0; r < ranks(); ++r)
      pairs_everywhere = pairs_everywhere && all[3 * r + 2] >= 0;
    if (pairs_everywhere)
      for (int r = 0; r < ranks(); ++r)
        pair_fit_.add(all[3 * r], all[3 * r + 1], all[3 * r + 2]);
  }
  b.imbalance = mean > 0 ? most / mean : 1.0;
  last_imbalance_ = b.imbalance;
  double slowest_sum = 0;
  for (double t : slowest)
    slowest_sum += t;
  last_phase_imbalance_ = mean > 0 ? slowest_sum / mean : 1.0;
  // Each phase's own spread: which phase's work is off, where the sum above says only how much.
  for (int p = 0; p < kPhases; ++p)
    last_phase_spread_[p] = seconds[p] > 0 ? slowest[p] / (seconds[p] / ranks()) : 0.0;
  ++checks_held_;
  if (b.imbalance <= scene_.parallel.imbalance)
    return b;
  // A re-partition saves about what the slowest rank spends over the mean an interval, for about
  // as many intervals as the last one held; it must save what the last one cost. Ranks sharing
  // a GPU measure an imbalance a re-partition cannot remove (each rank's passes stretched by the
  // others'): 2 ranks on one H200 re-partitioned the 8M dam break 3-9 times in 1,500 steps, up
  // to 0.77 s each, half the run (docs/PERFORMANCE.md, P5 on one H200). Every rank decides
  // alike: most, mean and the cost are the job's.
  if (scene_.parallel.payback &&
      !Decomposition::repartition_pays(most, mean, checks_held_, last_repartition_seconds_)) {
    ++declined_;
    return b;
  }
  const auto started = std::chrono::steady_clock::now();
  const Timed timed{exchange_seconds_};
  std::optional<stage_parts::Scope> part_now; // under --profile: where a re-partition's time goes
  part_now.emplace("balance: the blocks' counts (re-partition)");
  // The job's counts per block now, and the blocks shared out anew (every rank alike). Counted
  // where the particles are: only a count a block comes to the host (the 8M dam break on 2 ranks
  // sharing an H200: 66 ms a re-partition with the positions copied and counted on the host).
  const BlockGrid& grid = decomposition_->grid();
  std::vector<double> counts(std::size_t(grid.count()) * kPhases, 0.0);
  const auto add = [&](const std::vector<std::uint32_t>& per_block, Phase p) {
    for (std::size_t k = 0; k < per_block.size(); ++k)
      counts[kPhases * k + static_cast<int>(p)] += per_block[k];
  };
  if (fluid)
    add(select_.block_counts(fluid->x, fluid->size()), Phase::Fluid);
  if (boundary)
    add(select_.block_counts(boundary->x, boundary->size(), boundary_owned_flags()),
        Phase::Boundary);
  if (knit_x) {
    // A knit point counts 1, and each coupling pair listed for it the weight measured so far.
    const double w = pairs_everywhere ? pair_fit_.weight() : 0.0;
    const HostValues<Vec3<T>> kx(*knit_x, knit_owned);
    for (std::size_t i = 0; i < kx.size(); ++i)
      counts[kPhases * grid.block_of(vec_cast<double>(kx[i])) + static_cast<int>(Phase::Knit)] +=
          1 + (w > 0 ? w * (*pairs)[i] : 0.0);
  }
  MPI_Allreduce(MPI_IN_PLACE, counts.data(), static_cast<int>(counts.size()), MPI_DOUBLE, MPI_SUM,
                mpi_.comm());
  std::vector<std::array<double, kPhases>> per_block(grid.count(), {0, 0, 0});
  std::array<double, kPhases> total{};
  for (int k = 0; k < grid.count(); ++k) {
    per_block[k] = {counts[kPhases * k], counts[kPhases * k + 1], counts[kPhases * k + 2]};
    for (int p = 0; p < kPhases; ++p)
      total[p] += per_block[k][p];
  }
  // Each phase's measured cost a particle, relative to the fluid's (the boundary's passes are
  // timed with the fluid's: its default stays); the knit's a substep.
  const auto per = [&](Phase p) {
    const int i = static_cast<int>(p);
    return total[i] > 0 && seconds[i] > 0 ? seconds[i] / total[i] : 0.0;
  };
  const double c_fluid = per(Phase::Fluid), c_knit = per(Phase::Knit);
  if (c_fluid > 0 && c_knit > 0)
    costs_.per_particle[static_cast<int>(Phase::Knit)] =
        c_knit / c_fluid / std::max(1, costs_.knit_substeps);
  // The particles balanced on the ranks already (each phase, by the costs just measured): a new
  // partition would balance them no better, and the time measured is not theirs. Only the counts
  // were spent (3.5 ms of the 8M dam break's 61 ms re-partition on 2 ranks sharing an H200).
  last_counted_imbalance_ = decomposition_->worst_phase_imbalance(per_block, costs());
  if (scene_.parallel.payback &&
      !Decomposition::repartition_promises(last_counted_imbalance_, decomposition_->tolerance(),
                                           decomposition_->landed())) {
    ++declined_balanced_;
    declined_counted_ = std::max(declined_counted_, last_counted_imbalance_);
    return b;
  }
  part_now.emplace("balance: METIS (re-partition)");
  const auto partitioning = std::chrono::steady_clock::now();
  decomposition_.emplace(
      Decomposition::partition(grid, per_block, costs(), ranks(), widths_.halo_weight));
  const double partition_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - partitioning).count();
  select_.set(*decomposition_, rank());
  migration_peers_ = neighbour_ranks(*decomposition_, rank(), grid.edge());
  // A block may change hands across the domain: every rank is a peer of this one exchange.
  const std::vector<int> everyone = other_ranks();
  part_now.emplace("balance: the fluid migrated (re-partition)");
  if (fluid) {
    // Chosen on the backend (only the leavers' indices come to the host); every wall closed:
    // nothing leaves the domain here, the rebuild after it removes the outflow.
    auto leaving = select_.departures(fluid->x, fluid->m, fluid->size(), Vec3<T>{}, Vec3<T>{},
                                      {true, true, true, true, true, true});
    auto state = fluid_state(*fluid, true);
    const std::size_t n = comm::migrate(*transport_, everyone, leaving.leaving, state, rows());
    fluid->resize(n);
    fluid_owned_ = n;
    all_owned();
  }
  part_now.emplace("balance: the boundary migrated (re-partition)");
  if (boundary)
    migrate_boundary(*boundary, true);
  part_now.reset();
  b.repartitioned = true;
  ++repartitions_;
  checks_held_ = 0;
  last_repartition_seconds_ =
      mpi_.max(std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count());
  last_partition_seconds_ = mpi_.max(partition_seconds);
  return b;
}

template <typename T>
std::vector<int> RankExchange<T>::owners(std::span<const Vec3<T>> x, bool others_dropped) const {
  std::vector<int> dest(x.size());
  const int me = rank();
  for (std::size_t i = 0; i < x.size(); ++i) {
    const int o = decomposition_->owner(vec_cast<double>(x[i]));
    dest[i] = others_dropped && o != me ? -1 : o;
  }
  return dest;
}

template <typename T>
std::vector<int> RankExchange<T>::other_ranks() const {
  std::vector<int> r;
  for (int k = 0; k < ranks(); ++k)
    if (k != rank())
      r.push_back(k);
  return r;
}

template <typename T>
void RankExchange<T>::remap(comm::HaloExchange& halo, const exec::DeviceBuffer<std::uint32_t>& perm,
                            std::size_t rows, std::size_t kept, std::size_t first_ghost) {
  // The dropped rows' entries stay unwritten: no list names them.
  inverse_.resize(rows);
  invert_permutation({backend_}, perm.data(), kept, inverse_.data());
  halo.remap(column(inverse_), first_ghost);
}

template <typename T>
void RankExchange<T>::fluid_rows_changed() {
  fluid_split_.current = false;
  ghost_list_current_ = false;
}

template <typename T>
exec::Rows RankExchange<T>::ghost_rows() {
  if (!fluid_halo_)
    return exec::Rows{nullptr, 0};
  if (!ghost_list_current_) {
    ghost_list_.resize(fluid_halo_->received());
    fluid_halo_->copy_ghost_rows(ghost_list_.data(), fluid_owned_);
    ghost_list_current_ = true;
  }
  return exec::Rows{ghost_list_.data(), ghost_list_.size()};
}

template <typename T>
void RankExchange<T>::settle_forces() {
  if (forces_pending())
    finish_forces();
}

template <typename T>
void RankExchange<T>::finish_forces() {
  if (!forces_pending())
    throw Error("internal: the forces' refresh finished while none is in flight");
  on_clock(2 * 2 + 1, [&] {
    const Timed timed{exchange_seconds_}, part{parts_.refresh};
    fluid_halo_->finish();
  });
}

template <typename T>
void RankExchange<T>::all_owned() {
  keep_.resize(fluid_owned_);
  exec::fill_flags({backend_}, keep_.data(), fluid_owned_, 1u, "ranks.owned");
  fluid_rows_changed();
}

template <typename T>
typename RankExchange<T>::SplitRows&
RankExchange<T>::split(const comm::HaloExchange& halo, SplitRows& out,
                       const std::function<void(exec::DeviceBuffer<std::uint32_t>&)>& owned) {
  if (out.current)
    return out;
  const Timed timed{exchange_seconds_}, part{parts_.refresh};
  // Flags on the backend, not a sorted union on the host: with lists off this runs every step.
  const exec::Exec ex{backend_};
  owned(out.flags);
  out.sent.resize(halo.sent());
  halo.copy_sent_rows(out.sent.data());
  exec::set_listed(ex, out.flags.data(), out.sent.data(), out.sent.size(), 0u, "ranks.interior");
  flagged_indices(ex, out.flags, out.scratch, out.interior, "ranks.interior");
  exec::flag_only(ex, out.flags.data(), out.flags.size(), out.sent.data(), out.sent.size(),
                  "ranks.border");
  flagged_indices(ex, out.flags, out.scratch, out.border, "ranks.border");
  out.current = true;
  return out;
}

template <typename T>
typename RankExchange<T>::SplitRows& RankExchange<T>::fluid_rows() {
  return split(*fluid_halo_, fluid_split_, [this](exec::DeviceBuffer<std::uint32_t>& flags) {
    flags.resize(keep_.size());
    flags.copy_from(keep_, keep_.size());
  });
}

template <typename T>
void RankExchange<T>::time_refreshes_on_device() {
  for (auto& c : refresh_clocks_)
    c = std::make_unique<exec::Stopwatch>(backend_);
}

template <typename T>
template <typename F>
void RankExchange<T>::on_clock(int k, F&& what) {
  exec::Stopwatch* clock = refresh_clocks_[k].get();
  if (clock)
    clock->start();
  what();
  if (clock)
    clock->stop();
}

template <typename T>
const typename RankExchange<T>::RefreshTimes& RankExchange<T>::collect_refresh_times() {
  for (int k = 0; k < kRefreshes; ++k)
    if (refresh_clocks_[2 * k]) {
      refresh_times_.pass[k] += refresh_clocks_[2 * k]->collect();
      refresh_times_.exchange[k] += refresh_clocks_[2 * k + 1]->collect();
    }
  refresh_uses_ = 0;
  return refresh_times_;
}

template <typename T>
void RankExchange<T>::overlapped(comm::HaloExchange& halo, const SplitRows* rows,
                                 std::span<const comm::Column> cols, std::size_t first_ghost,
                                 std::size_t n, const Pass& pass, int refresh, bool finish) {
  // Two events an interval: read every few hundred refreshes (one host wait), as the stages'.
  if (refresh_clocks_[0] && ++refresh_uses_ >= 3 * 256)
    collect_refresh_times();
  if (!rows) {
    on_clock(2 * refresh, [&] {
      pass(owned_rows(n)); // the ghosts take their owners' values in the exchange
      if (!finish) {
        const Timed timed{exchange_seconds_}, part{parts_.refresh};
        halo.start(cols, first_ghost);
      }
    });
    if (finish)
      on_clock(2 * refresh + 1, [&] {
        const Timed timed{exchange_seconds_}, part{parts_.refresh};
        halo.exchange(cols, first_ghost);
      });
    return;
  }
  on_clock(2 * refresh, [&] {
    const exec::Rows border{rows->border.data(), rows->border.size()};
    const exec::Rows interior{rows->interior.data(), rows->interior.size()};
    const auto start = [&] {
      const Timed timed{exchange_seconds_}, part{parts_.refresh};
      halo.start(cols, first_ghost);
    };
    if (!side_) {
      pass(border);
      start();
      pass(interior);
      return;
    }
    // The border first (its blocks placed before the interior's fill the GPU), the interior
    // beside it and the exchange; the pack and the transports stay ordered after the border on
    // the legacy default stream. The two passes write disjoint rows and the pack reads only
    // border rows, so nothing between fork and join needs more order than this.
    side_->fork();
    pass(border);
    {
      const exec::OnSideStream beside(*side_);
      pass(interior);
    }
    start();
    side_->join();
  });
  if (finish)
    on_clock(2 * refresh + 1, [&] {
      const Timed timed{exchange_seconds_}, part{parts_.refresh};
      halo.finish();
    });
}

template <typename T>
exec::Rows RankExchange<T>::owned_rows(std::size_t n) const {
  if (keep_.size() != n)
    throw Error("internal: a pass over " + std::to_string(n) + " fluid rows, " +
                std::to_string(keep_.size()) + " of them flagged owned or not");
  return exec::Rows{nullptr, n, keep_.data()};
}

template <typename T>
void RankExchange<T>::owned_pass(std::size_t n, const Pass& pass) {
  if (!fluid_halo_) {
    pass(exec::Rows{nullptr, n});
    return;
  }
  if (!overlap_) {
    pass(owned_rows(n));
    return;
  }
  const SplitRows& rows = fluid_rows();
  pass(exec::Rows{rows.border.data(), rows.border.size()});
  pass(exec::Rows{rows.interior.data(), rows.interior.size()});
}

template <typename T>
void RankExchange<T>::boundary_sorted(const exec::DeviceBuffer<std::uint32_t>& perm_buffer,
                                      std::size_t n) {
  if (!boundary_halo_)
    return;
  remap(*boundary_halo_, perm_buffer, n, n, boundary_own_count_);
  const HostValues<std::uint32_t> perm(perm_buffer, n); // at the start and re-partitions only
  boundary_owned_ = pick(boundary_owned_, perm.span());
  boundary_flags_uploaded_ = false;
}

template <typename T>
typename RankExchange<T>::Removed
RankExchange<T>::rebuild(FluidSet<T>& fluid, const Vec3<T>& lo, const Vec3<T>& hi,
                         const std::array<bool, 6>& walls, bool acceleration,
                         const WiderCells<T>& beside_walls) {
  settle_forces();
  if (widths_.walls > 0 && !beside_walls.cells)
    throw Error("internal: the fluid's ghosts chosen without the cells beside walls");
  const Timed timed{exchange_seconds_}, part{parts_.migration};
  const std::size_t n = fluid.size();
  const exec::Exec ex{backend_};
  // Who leaves (to another rank, or out of the domain past an open side as the single-rank
  // sort removes it), chosen on the fluid's backend: only the leavers' indices come back. The
  // ghosts kept since the last sort ("verlet" lists) are dropped by the same flags (keep_: 1 for
  // every row where none are held).
  std::optional<stage_parts::Scope> part_now;
  part_now.emplace("grid.fluid: the leavers chosen (N ranks)");
  auto leaving = select_.departures(fluid.x, fluid.m, n, lo, hi, walls, keep_.data());
  leaving.leaving.in_place = true;
  fluid_halo_.reset(); // the kept ghosts' halo
  // Every state column the steps to come read; a where the half kick reads it before the next
  // forces pass writes it (the migrants' a was left behind before, and a drop emitted into
  // another rank's region then fell with another rank's a: the absorbing hammock parted).
  auto state = fluid_state(fluid, acceleration);
  part_now.emplace("grid.fluid: the leavers migrated (N ranks)");
  const std::size_t rows_now =
      comm::migrate(*transport_, migration_peers_, leaving.leaving, state, rows());
  // The rows to keep: those that stayed, then every arrival (and below, every ghost).
  alive_.resize(rows_now);
  exec::copy_bytes(alive_.data(), backend_, leaving.leaving.keep, backend_,
                   n * sizeof(std::uint32_t));
  exec::fill_flags(ex, alive_.data() + n, rows_now - n, 1u, "ranks.alive");
  // The ghosts: every owned particle within the support of another rank's region goes there.
  part_now.emplace("grid.fluid: the ghosts chosen (N ranks)");
  WiderCells<T> wider = beside_walls;
  wider.width = widths_.walls;
  auto gl = select_.ghost_rows(fluid.x, rows_now, widths_.fluid, rows(), alive_.data(),
                               widths_.walls > 0 ? wider : WiderCells<T>{});
  part_now.emplace("grid.fluid: the ghosts' halo set up (N ranks)");
  fluid_halo_.emplace(*transport_, std::move(gl.peers), std::move(gl.send), rows());
  part_now.emplace("grid.fluid: the ghosts received (N ranks)");
  const std::size_t received = fluid_halo_->received(), total = rows_now + received;
  fluid.resize(total);
  const comm::Column cols[] = {column(fluid.x),         column(fluid.v), column(fluid.m),
                               column(fluid.rho),       column(fluid.p), column(fluid.drho),
                               column(fluid.drho_prev), column(fluid.id)};
  fluid_halo_->exchange(cols, rows_now);
  alive_.resize(total);
  exec::fill_flags(ex, alive_.data() + rows_now, received, 1u, "ranks.alive");
  // Until the sort: the rows before the ghosts (the dropped among them) count as owned.
  fluid_owned_ = rows_now;
  keep_.resize(total);
  flag_below(ex, nullptr, total, rows_now, keep_.data());
  fluid_rows_changed();
  return Removed{leaving.removed, leaving.removed_mass};
}

template <typename T>
void RankExchange<T>::fluid_sorted(const exec::DeviceBuffer<std::uint32_t>& perm_buffer,
                                   std::size_t rows, std::size_t kept) {
  const Timed timed{exchange_seconds_}, part{parts_.migration};
  const std::size_t received = fluid_halo_ ? fluid_halo_->received() : 0;
  if (fluid_halo_)
    remap(*fluid_halo_, perm_buffer, rows, kept, fluid_owned_);
  // The owned were the rows before the ghosts; the dropped ones are gone.
  keep_.resize(kept);
  flag_below({backend_}, perm_buffer.data(), kept, fluid_owned_, keep_.data());
  fluid_owned_ = kept - received;
  fluid_rows_changed();
}

template <typename T>
void RankExchange<T>::fluid_pass(std::span<const comm::Column> cols, std::size_t n,
                                 const Pass& pass, bool overlap, int refresh, bool finish) {
  settle_forces();
  if (!fluid_halo_) { // collective over the peers: also where this rank received no ghost
    pass(exec::Rows{nullptr, n});
    return;
  }
  overlapped(*fluid_halo_, overlap ? &fluid_rows() : nullptr, cols, fluid_owned_, n, pass, refresh,
             finish);
}

template <typename T>
void RankExchange<T>::refresh_density(FluidSet<T>& fluid, const Pass& pass) {
  const comm::Column cols[] = {column(fluid.rho), column(fluid.p), column(fluid.vp),
                               column(fluid.vol)};
  fluid_pass(cols, fluid.size(), pass, overlap_, 0);
}

template <typename T>
void RankExchange<T>::walls_pass(std::size_t n, const Pass& pass) {
  // Every wall, owned and ghost: a ghost wall's fluid is at hand (widths_.walls), so its pressure
  // is its owner's, bit for bit, without an exchange (test_distributed_mpi).
  on_clock(2 * 1, [&] { pass(exec::Rows{nullptr, n}); }); // (its exchange's clock stays 0)
}

template <typename T>
void RankExchange<T>::refresh(std::span<const comm::Column> columns) {
  settle_forces();
  const Timed timed{exchange_seconds_}, part{parts_.refresh};
  if (!fluid_halo_) // collective over the peers: also where this rank received no ghost
    return;
  fluid_halo_->exchange(columns, fluid_owned_);
}

template <typename T>
void RankExchange<T>::refresh_motion(FluidSet<T>& fluid) {
  const comm::Column cols[] = {column(fluid.v), column(fluid.a),    column(fluid.rho),
                               column(fluid.p), column(fluid.drho), column(fluid.drho_prev)};
  refresh(cols);
}

template <typename T>
void RankExchange<T>::refresh_forces(FluidSet<T>& fluid, bool continuity, const Pass& pass,
                                     bool defer) {
  const comm::Column all[] = {column(fluid.a), column(fluid.rho), column(fluid.drho),
                              column(fluid.drho_prev)};
  // [parallel] overlap false: the exchange right after the pass, as every refresh then.
  fluid_pass(std::span<const comm::Column>(all, continuity ? 4 : 1), fluid.size(), pass,
             overlap_short_, 2, !(defer && overlap_));
}

template <typename T>
void RankExchange<T>::refresh_positions(FluidSet<T>& fluid) {
  const comm::Column cols[] = {column(fluid.x), column(fluid.v)};
  refresh(cols);
}

template <typename T>
void RankExchange<T>::remove(const exec::Exec& ex, FluidSet<T>& fluid,
                             const exec::DeviceBuffer<std::uint32_t>& keep) {
  settle_forces();
  const Timed timed{exchange_seconds_}, part{parts_.refresh};
  fluid.keep_flagged(ex, keep);
  fluid_owned_ = fluid.size();
  all_owned();
  fluid_halo_.reset();
}

template <typename T>
void RankExchange<T>::appended(const FluidSet<T>& fluid) {
  if (fluid_halo_)
    throw Error("rank exchange: particles appended to the fluid while it holds ghosts");
  fluid_owned_ = fluid.size();
  all_owned();
}

template <typename T>
void RankExchange<T>::drop_ghosts(const exec::Exec& ex, FluidSet<T>& fluid) {
  settle_forces();
  if (fluid.size() != fluid_owned_)
    remove(ex, fluid, keep_); // the owned flags
  else
    fluid_halo_.reset(); // none received here, but this rank's sends were the halo's too
}

template class RankExchange<float>;
template class RankExchange<double>;

} // namespace kf
