#include "kernels/coupling/KnitFluidCoupling.hpp"

#include "kernels/exec/ScanOnDevice.hpp"
#include "kernels/sph/SmoothingKernels.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

namespace kf {

namespace {

/// The rows' flags (row r holds a near particle: r below the near count), each near particle's
/// position in its row (those past the rows held have none) and the near count: one launch over
/// the larger of the two (the fluid may have shrunk below the rows kept), at least one. Each
/// thread takes the count from the scan's last entry (the scan leaves the total out: a launch a
/// build fewer); the first writes it for the knit's rows and the host's read.
template <typename T>
struct RowsPlaced {
  const std::uint32_t* near;
  const std::uint32_t* row_of;
  std::uint32_t* count;
  const Vec3<T>* x;
  Vec3<T>* row_x;
  std::uint32_t* active;
  std::uint32_t rows, fluid;
  KF_HD void operator()(std::size_t k) const {
    const std::uint32_t total = exec::exclusive_scan_total(near, row_of, fluid);
    if (k == 0)
      *count = total;
    if (k < rows)
      active[k] = k < total ? 1u : 0u;
    if (k < fluid && near[k] && row_of[k] < rows)
      row_x[row_of[k]] = x[k];
  }
};

} // namespace

template <typename T>
KnitFluidCoupling<T>::KnitFluidCoupling(exec::Backend b, KernelType kernel,
                                        const CouplingParams<T>& params,
                                        const GridGeometry<T>& grid, std::uint32_t list_capacity,
                                        std::uint32_t knit_capacity)
    : kernel_(kernel), params_(params), grid_(b, grid, 1, 0, "coupling.grid"),
      watch_(b, (grid.cell - coupling_reach(params)) / T(3), "coupling.moved"),
      saturation_(b, 0, "coupling.saturation"), pressure_(b, 0, "coupling.pressure"),
      fluid_mass_(b, 0, "coupling.fluid_mass"), x_(b, 0, "coupling.knit_x"),
      v_(b, 0, "coupling.knit_v"), xs_(b, 0, "coupling.knit_x_sorted"), m_(b, 0, "coupling.knit_m"),
      p_(b, 0, "coupling.knit_p"), impulse_(b, 0, "coupling.impulse"),
      near_flag_(b, 0, "coupling.near_flag"), row_of_(b, 0, "coupling.row_of"),
      row_active_(b, 0, "coupling.row_active"), near_count_(b, 1, "coupling.near_count"),
      row_x_(b, 0, "coupling.row_x"), near_read_(b, 1, "coupling.near_count"),
      list_(b, "coupling.lists"), knit_rows_(b, "coupling.knit_rows"),
      pair_force_(b, 0, "coupling.pair_force"),
      list_skin_(T(2) * (grid.cell - coupling_reach(params)) / T(3)), list_capacity_(list_capacity),
      knit_capacity_(knit_capacity ? knit_capacity : list_capacity), cell_(grid.cell) {
  const T reach = coupling_reach(params);
  if (!(grid.cell > reach))
    throw Error("knit-fluid coupling: grid cell " + std::to_string(double(grid.cell)) +
                " m is not larger than the coupling's reach " + std::to_string(double(reach)) +
                " m");
}

template <typename T>
void KnitFluidCoupling<T>::sort_knit(const exec::Exec& ex, KnitSet<T>& knit) {
  if (x_.size() != knit.size() || !(watch_.moved(ex, knit.x) <= watch_.skin()))
    sort_now(ex, knit);
}

template <typename T>
void KnitFluidCoupling<T>::sort_now(const exec::Exec& ex, KnitSet<T>& knit,
                                    const exec::DeviceBuffer<Vec3<T>>& at) {
  const std::size_t n = knit.size();
  grid_.build(ex, at.data(), n, ties_by_id_ ? knit.id.data() : nullptr);
  watch_.reset(ex, at);
  ++sorts_;
  x_.resize(n);
  v_.resize(n);
  m_.resize(n);
  p_.resize(n); // m_ and p_ are gathered by begin_step every step (the wet mass changes)
  xs_.resize(n);
  exec::gather(ex, perm(), at, xs_, "coupling.gather");
}

template <typename T>
void KnitFluidCoupling<T>::restore(const exec::Exec& ex, KnitSet<T>& knit,
                                   const typename SkinWatch<T>::State& s) {
  if (s.x0.size() != knit.size())
    throw Error("restart: the coupling's sorted knit positions hold " +
                std::to_string(s.x0.size()) + " points, the knit " + std::to_string(knit.size()));
  exec::DeviceBuffer<Vec3<T>> at(ex.backend, 0, "coupling.restart");
  at.assign(s.x0);
  sort_now(ex, knit, at);
  watch_.restore(s);
}

template <typename T>
void KnitFluidCoupling<T>::sync_knit(const exec::Exec& ex, KnitSet<T>& knit) {
  sort_knit(ex, knit);
  exec::gather(ex, perm(), knit.x, x_, "coupling.gather");
}

template <typename T>
void KnitFluidCoupling<T>::update_saturation(const exec::Exec& ex, KnitSet<T>& knit,
                                             const FluidSide<T>& fluid, PoreMass<T> pores,
                                             const std::function<void()>& share) {
  const std::size_t n = knit.size();
  const bool fresh = saturation_.size() != n;
  saturation_.resize(n);
  pressure_.resize(n);
  fluid_mass_.resize(n);
  conserving_ = pores.absorbed != nullptr;
  if (conserving_) {
    const T* absorbed = pores.absorbed;
    const T* capacity = pores.capacity;
    T* s = saturation_.data();
    T* P = pressure_.data();
    T* mf = fluid_mass_.data();
    const T scale = params_.pressure_scale;
    exec::for_each(
        ex, n,
        [=] KF_HD(std::size_t i) {
          const T si = absorbed[i] / capacity[i];
          s[i] = si;
          P[i] = scale * leverett_j(si > T(1.5) ? T(1.5) : si);
          mf[i] = absorbed[i];
        },
        "coupling.saturation");
  } else if (params_.capillary) {
    with_kernel<T>(kernel_, params_.h, [&](auto k) {
      using K = decltype(k);
      exec::for_each_lanes<4>(ex, n,
                              SaturationEvaluator<T, K>{k, params_, knit.x.data(), knit.m.data(),
                                                        fluid.f.x, fluid.f.m, fluid.cells,
                                                        fluid.near, saturation_.data(),
                                                        pressure_.data(), fluid_mass_.data()},
                              "coupling.saturation");
    });
  } else if (fresh) { // contact only: no saturation, zero once
    exec::fill(ex, saturation_, T(0), "coupling.saturation");
    exec::fill(ex, pressure_, T(0), "coupling.saturation");
    exec::fill(ex, fluid_mass_, T(0), "coupling.saturation");
  }
  if (share)
    share();
}

template <typename T>
void KnitFluidCoupling<T>::begin_step(const exec::Exec& ex, KnitSet<T>& knit,
                                      const FluidSide<T>& fluid, PoreMass<T> pores, T motion,
                                      const std::function<void()>& share, FluidAnchor<T> anchor) {
  update_saturation(ex, knit, fluid, pores, share);
  begin_lists(ex, knit, fluid, motion, anchor);
}

template <typename T>
void KnitFluidCoupling<T>::begin_lists(const exec::Exec& ex, KnitSet<T>& knit,
                                       const FluidSide<T>& fluid, T motion, FluidAnchor<T> anchor) {
  const std::size_t n = knit.size();
  watch_.before_step(ex, knit.x, motion, x_.size() != n, [&] { sort_now(ex, knit); });
  exec::gather(ex, perm(), pressure_, p_, "coupling.gather");
  exec::gather(ex, perm(), knit.m, m_, "coupling.gather"); // wet mass changes
  impulse_.resize(fluid.f.n);
  exec::fill(ex, impulse_, Vec3<T>{T(0), T(0), T(0)}, "coupling.impulse");
  // The sorted copies x_, v_ and the watch's record are the first add_forces' (the knit step's
  // opening forces, before anything moves): none here.
  // The lists hold, for each fluid particle near the knit, the knit points within reach + 2
  // skins of it, both where the lists were built for: the knit where its grid was sorted (a
  // point moves at most a skin from there while the lists are read: the substeps watch it), the
  // fluid where it is now or, with an anchor, where the fluid's own lists were built (the fluid
  // at most a skin from there: the anchor's bound, read on the host). The fluid does not move
  // through the knit's substeps, so lists built for an anchor last until the fluid's next sort,
  // the knit grid's next sort, or the anchor's bound passing the skin; the walk of 27 cells
  // (reach + 2 skins < the cell less a skin) finds every pair.
  const bool anchored = anchor.x0 && anchor.moved <= T(0.99) * watch_.skin();
  const Built now{anchor.sorts, sorts_, fluid.f.n, n};
  flag_slack_ = anchored ? watch_.skin() : T(0);
  if (anchored && built_ == now)
    return;
  const Vec3<T>* at = anchored ? anchor.x0 : fluid.f.x;
  find_fluid_near_knit(ex, at, fluid.f.n);
  size_rows(ex, fluid.f.n);
  exec::for_each(ex, std::max({rows_, fluid.f.n, std::size_t{1}}),
                 RowsPlaced<T>{near_flag_.data(), row_of_.data(), near_count_.data(), at,
                               row_x_.data(), row_active_.data(), static_cast<std::uint32_t>(rows_),
                               static_cast<std::uint32_t>(fluid.f.n)},
                 "coupling.rows");
  const T r = coupling_reach(params_) + list_skin_;
  list_.template build_for<kFluidSideLanes>(ex, row_x_.data(), row_active_.data(), rows_,
                                            xs_.data(), grid_.view(), r * r, list_capacity_);
  // The same pairs seen from the knit, for its side of every substep (the lists' rows hold
  // grid slots: perm maps them to the knit's points). Rows in the fluid's order: the knit's
  // sums go in the order a row a fluid particle gave them.
  knit_rows_.build(ex, list_.view(), row_active_.data(), perm().data(), n, knit_capacity_,
                   near_count_.data());
  near_read_.start(near_count_.data());
  // A slot a pair of these lists, written by the fluid's side before the knit's reads it: the
  // old lists' forces are not kept where it grows.
  pair_force_.resize_snug_discarding(list_.view().capacity * rows_);
  // Only a build for an anchor may be kept: one for the fluid where it is now is for this step.
  built_ = anchored ? std::optional<Built>(now) : std::nullopt;
  ++list_builds_;
}

template <typename T>
void KnitFluidCoupling<T>::size_rows(const exec::Exec& ex, std::size_t n) {
  row_of_.resize(n);
  // The first build waits for its own count (once a run: the scan's total); later ones take the
  // last build's, which RowsPlaced writes and every build starts reading behind it (a build with
  // more near particles than rows is still exact: see the header).
  exec::exclusive_scan_on_device(ex, near_flag_, row_of_,
                                 rows_sized_ ? nullptr : near_count_.data(), "coupling.rows");
  if (!rows_sized_)
    near_read_.start(near_count_.data());
  rows_sized_ = true;
  const std::size_t near = near_read_.wait()[0];
  last_near_ = static_cast<std::uint32_t>(near);
  if (rows_for(near, n) > rows_) {
    rows_ = rows_for(near, n);
    // Written anew by RowsPlaced after every sizing (every row's flag, the near rows' x): a copy
    // of the old would carry rows past the near count never written (initcheck's finding).
    row_active_.resize_snug_discarding(rows_);
    row_x_.resize_snug_discarding(rows_);
  }
}

template <typename T>
void KnitFluidCoupling<T>::find_fluid_near_knit(const exec::Exec& ex, const Vec3<T>* x,
                                                std::size_t n) {
  near_flag_.resize(n);
  const CellView<T> knit_cells = grid_.view();
  std::uint32_t* flag = near_flag_.data();
  exec::for_each(
      ex, n, [=] KF_HD(std::size_t j) { flag[j] = knit_cells.has_candidates(x[j]) ? 1u : 0u; },
      "coupling.near");
}

template <typename T>
void KnitFluidCoupling<T>::add_forces(const exec::Exec& ex, KnitSet<T>& knit,
                                      const FluidSide<T>& fluid, T weight,
                                      const KnitForceTerms<T>* own, const WatchedCopies<T>& with) {
  observe_gather(ex, knit.x, knit.v, WatchedCopies<T>{&watch_, &perm(), &x_, &v_}, with,
                 "knit.moved");
  with_kernel<T>(kernel_, params_.h, [&](auto k) {
    using K = decltype(k);
    exec::for_each_lanes<kFluidSideLanes>(
        ex, fluid.f.n,
        FluidCouplingEvaluator<T, K>{k, params_, fluid.f,
                                     SortedKnitSide<T>{x_.data(), v_.data(), m_.data(), p_.data()},
                                     grid_.view(), weight, impulse_.data(), near_flag_.data(),
                                     row_of_.data(), list_.view(), watch_.moved2(), watch_.skin2(),
                                     (walk_margin() - flag_slack_) * (walk_margin() - flag_slack_),
                                     static_cast<std::uint32_t>(x_.size()), pair_force_.data()},
        "coupling.fluid");
    auto kv = knit.view();
    kv.n = active(knit);
    const T* absorbed = params_.capillary && !conserving_ ? fluid_mass_.data() : nullptr;
    const auto knit_side = KnitCouplingEvaluator<T, K>{k,
                                                       params_,
                                                       kv,
                                                       pressure_.data(),
                                                       absorbed,
                                                       fluid.f.x,
                                                       fluid.f.v,
                                                       fluid.f.m,
                                                       fluid.f.rho,
                                                       fluid.cells,
                                                       fluid.near,
                                                       knit_rows_.view(),
                                                       knit_rows_.incomplete(),
                                                       pair_force_.data(),
                                                       watch_.moved2(),
                                                       watch_.skin2()};
    if (own) // after the fluid side: the knit's side reads the pair forces it kept
      knit_forces_with(ex, kv.n, *own, knit_side, "knit.forces");
    else
      exec::for_each_lanes<kKnitLanes>(ex, kv.n, knit_side, "coupling.knit");
  });
}

template <typename T>
void KnitFluidCoupling<T>::apply_impulses(const exec::Exec& ex, FluidView<T> f) {
  const Vec3<T>* J = impulse_.data();
  exec::for_each(
      ex, f.n, [=] KF_HD(std::size_t j) { f.v[j] += J[j] * (T(1) / f.m[j]); }, "coupling.impulse");
}

namespace {
struct CouplingStatsOp {
  KF_HD KF_INLINE CouplingStats operator()(const CouplingStats& a, const CouplingStats& b) const {
    return {a.contacts + b.contacts,
            a.energy + b.energy,
            a.absorbed_mass + b.absorbed_mass,
            a.max_saturation > b.max_saturation ? a.max_saturation : b.max_saturation,
            a.mean_saturation + b.mean_saturation,
            a.wet_points + b.wet_points};
  }
};
} // namespace

template <typename T>
CouplingStats KnitFluidCoupling<T>::stats(const exec::Exec& ex, KnitSet<T>& knit,
                                          const FluidSide<T>& fluid) {
  const std::size_t n = active(knit);
  if (saturation_.size() != knit.size())
    throw Error("knit-fluid coupling: stats before the first begin_step");
  const T* s = saturation_.data();
  const T* mf = fluid_mass_.data();
  const Vec3<T>* kx = knit.x.data();
  const FluidView<T> f = fluid.f;
  const CellView<T> cells = fluid.cells;
  const T reach = params_.contact ? params_.reach : T(0), reach2 = reach * reach;
  const double k = double(params_.dem.k);
  CouplingStats st = exec::transform_reduce(
      ex, n, CouplingStats{}, CouplingStatsOp{},
      [=] KF_HD(std::size_t i) {
        CouplingStats c;
        c.absorbed_mass = double(mf[i]);
        c.max_saturation = double(s[i]);
        c.mean_saturation = double(s[i]);
        c.wet_points = s[i] > T(0.01) ? 1 : 0;
        if (reach2 > T(0))
          cells.for_each_candidate(kx[i], [&](std::uint32_t j) {
            const T r2 = norm2(kx[i] - f.x[j]);
            if (r2 < reach2) {
              ++c.contacts;
              const double u = double(reach - ksqrt(r2));
              c.energy += 0.5 * k * u * u;
            }
          });
        return c;
      },
      "coupling.stats");
  if (n)
    st.mean_saturation /= double(n);
  return st;
}

template <typename T>
std::size_t KnitFluidCoupling<T>::bytes() const {
  return grid_.bytes() + watch_.bytes() + near_flag_.capacity_bytes() + row_of_.capacity_bytes() +
         row_active_.capacity_bytes() + row_x_.capacity_bytes() + list_.bytes() +
         knit_rows_.bytes() + pair_force_.capacity_bytes() + saturation_.capacity_bytes() +
         pressure_.capacity_bytes() + fluid_mass_.capacity_bytes() + x_.capacity_bytes() +
         v_.capacity_bytes() + xs_.capacity_bytes() + m_.capacity_bytes() + p_.capacity_bytes() +
         impulse_.capacity_bytes();
}

template <typename T>
typename KnitFluidCoupling<T>::Footprint
KnitFluidCoupling<T>::footprint(const GridGeometry<T>& grid, std::uint32_t list_capacity,
                                std::uint32_t knit_capacity) {
  constexpr std::size_t u = sizeof(std::uint32_t), t = sizeof(T), v = sizeof(Vec3<T>);
  const std::size_t row = NeighbourList<T>::whole_groups(list_capacity);
  const std::size_t knit_row =
      NeighbourList<T>::whole_groups(knit_capacity ? knit_capacity : list_capacity);
  Footprint f;
  f.grid = std::size_t(grid.cells()) * 3 * u; // a cell's start, end and rank
  f.per_fluid = u + v + u;                    // its near flag, impulse and row
  // Whether it is one, its particle's position, its count, its slots and their pair forces.
  f.per_row = u + v + u + row * (u + v);
  // The grid's key and permutation, the watch's reference, the transposed rows (a count and the
  // build's unsorted slots and keys beside the sorted slots), the sorted and per-step copies
  // (saturation, pressure, fluid mass; x, v, the sort's x; m, p).
  f.per_knit = 2 * u + v + u + knit_row * 3 * u + 3 * t + 3 * v + 2 * t;
  return f;
}

template <typename T>
std::size_t KnitFluidCoupling<T>::near_bound(const GridGeometry<T>& grid, const Vec3<T>* knit_x,
                                             std::size_t knit, double spacing) {
  std::vector<std::uint8_t> near(grid.cells(), 0);
  std::size_t cells = 0;
  for (std::size_t i = 0; i < knit; ++i) {
    int ix, iy, iz;
    grid.coords(knit_x[i], ix, iy, iz);
    for (int z = std::max(iz - 1, 0); z <= std::min(iz + 1, grid.nz - 1); ++z)
      for (int y = std::max(iy - 1, 0); y <= std::min(iy + 1, grid.ny - 1); ++y)
        for (int x = std::max(ix - 1, 0); x <= std::min(ix + 1, grid.nx - 1); ++x) {
          std::uint8_t& c = near[grid.linear(x, y, z)];
          cells += c ? 0 : 1;
          c = 1;
        }
  }
  const double per_cell = std::pow(double(grid.cell) / spacing, 3.0);
  return static_cast<std::size_t>(std::ceil(1.05 * per_cell * double(cells)));
}

template class KnitFluidCoupling<float>;
template class KnitFluidCoupling<double>;

} // namespace kf
