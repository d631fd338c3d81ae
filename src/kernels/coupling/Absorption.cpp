#include "kernels/coupling/Absorption.hpp"

#include "core/Error.hpp"

#include <algorithm>
#include <cmath>

namespace kf {

double darcy_stable_substep(const std::vector<double>& capacity,
                            const std::vector<std::array<std::uint32_t, 2>>& links,
                            const std::vector<double>& conductance, double pressure_scale) {
  std::vector<double> sum_k(capacity.size(), 0.0);
  for (std::size_t l = 0; l < links.size(); ++l) {
    sum_k[links[l][0]] += conductance[l];
    sum_k[links[l][1]] += conductance[l];
  }
  double h = 1e30; // no link: no limit
  for (std::size_t i = 0; i < capacity.size(); ++i)
    if (sum_k[i] > 0)
      h = std::min(h, 0.5 * capacity[i] / (4.5 * pressure_scale * sum_k[i]));
  return h;
}

template <typename T>
ConservingAbsorption<T>::ConservingAbsorption(
    exec::Backend b, const AbsorptionParams<T>& params, const std::vector<T>& dry_mass,
    const std::vector<T>& capacity, const std::vector<std::array<std::uint32_t, 2>>& links,
    const std::vector<double>& conductance)
    : params_(params), dry_(b, 0, "absorb.dry"), absorbed_(b, 0, "absorb.absorbed"),
      capacity_(b, 0, "absorb.capacity"), delta_(b, 0, "absorb.delta"),
      s_sorted_(b, 0, "absorb.s_sorted"), link_start_(b, 0, "absorb.link_start"),
      link_other_(b, 0, "absorb.link_other"), target_(b, 0, "absorb.target"),
      keep_(b, 0, "absorb.keep"), emit_(b, 0, "absorb.emit"), offsets_(b, 0, "absorb.offsets"),
      link_k_(b, 0, "absorb.link_k"), degree_(b, 0, "absorb.degree"),
      fraction_(b, 0, "absorb.fraction"), drop_id_(b, 0, "absorb.drop_id"),
      dmom_(b, 0, "absorb.delta_momentum"), start_(b, 0, "absorb.start") {
  const std::size_t n = dry_mass.size();
  mesh_dry_ = dry_mass;
  mesh_capacity_ = capacity;
  absorbed_.assign(std::vector<T>(n, T(0)));
  delta_.resize(n);
  // Each link in both ends' rows (gather: each point sums its own fluxes).
  std::vector<std::uint32_t> start(n + 1, 0), other(2 * links.size());
  std::vector<T> k(2 * links.size());
  for (const auto& l : links) {
    ++start[l[0] + 1];
    ++start[l[1] + 1];
  }
  for (std::size_t i = 0; i < n; ++i)
    start[i + 1] += start[i];
  std::vector<std::uint32_t> fill(start.begin(), start.end() - 1);
  for (std::size_t l = 0; l < links.size(); ++l) {
    const auto [i, j] = links[l];
    other[fill[i]] = j;
    k[fill[i]++] = static_cast<T>(conductance[l]);
    other[fill[j]] = i;
    k[fill[j]++] = static_cast<T>(conductance[l]);
  }
  mesh_start_ = std::move(start);
  mesh_other_ = std::move(other);
  mesh_k_ = std::move(k);
  whole();
  stable_substep_ = darcy_stable_substep(std::vector<double>(capacity.begin(), capacity.end()),
                                         links, conductance, double(params.pressure_scale));
}

template <typename T>
void ConservingAbsorption<T>::whole() {
  const std::size_t n = mesh_dry_.size();
  dry_.assign(mesh_dry_);
  capacity_.assign(mesh_capacity_);
  std::vector<T> degree(n);
  for (std::size_t i = 0; i < n; ++i)
    degree[i] = static_cast<T>(mesh_start_[i + 1] - mesh_start_[i]);
  link_start_.assign(mesh_start_);
  link_other_.assign(mesh_other_);
  link_k_.assign(mesh_k_);
  degree_.assign(degree);
}

template <typename T>
void ConservingAbsorption<T>::localize(const std::vector<std::uint64_t>& ids, std::size_t owned) {
  const std::size_t n = ids.size();
  std::vector<std::int64_t> local(mesh_start_.size() - 1, -1); // id -> local index
  for (std::size_t k = 0; k < n; ++k)
    local[ids[k]] = static_cast<std::int64_t>(k);
  std::vector<std::uint32_t> start(n + 1, 0), other;
  std::vector<T> k, degree(n);
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint64_t id = ids[i];
    degree[i] = static_cast<T>(mesh_start_[id + 1] - mesh_start_[id]);
    if (i < owned)
      for (std::uint32_t e = mesh_start_[id]; e < mesh_start_[id + 1]; ++e) {
        const std::int64_t j = local[mesh_other_[e]];
        if (j < 0)
          throw Error("absorption on N ranks: point " + std::to_string(mesh_other_[e]) +
                      ", linked to an owned point, is neither owned nor a ghost here");
        other.push_back(static_cast<std::uint32_t>(j));
        k.push_back(mesh_k_[e]);
      }
    start[i + 1] = static_cast<std::uint32_t>(other.size());
  }
  link_start_.assign(start);
  link_other_.assign(other);
  link_k_.assign(k);
  degree_.assign(degree);
}

template <typename T>
typename ConservingAbsorption<T>::Absorbed
ConservingAbsorption<T>::absorb(const exec::Exec& ex, KnitSet<T>& knit, FluidSet<T>& fluid,
                                CellView<T> fluid_cells, KnitFluidCoupling<T>& coupling,
                                const AbsorptionSplit<T>* split) {
  const std::size_t nf = fluid.size(), n = knit.size();
  // Split: every rank takes part in the exchanges below, whatever it holds.
  if (!split && (nf == 0 || n == 0))
    return {};
  coupling.sync_knit(ex, knit);
  const auto& perm = coupling.perm();
  // Saturation in the grid's order, for the fluid side's choice.
  s_sorted_.resize(n);
  {
    const T* a = absorbed_.data();
    const T* c = capacity_.data();
    const std::uint32_t* pp = perm.data();
    T* ss = s_sorted_.data();
    exec::for_each(
        ex, n, [=] KF_HD(std::size_t k) { ss[k] = a[pp[k]] / c[pp[k]]; }, "absorb.saturation");
  }
  target_.resize(nf);
  exec::for_each_lanes<kFluidSideLanes>(
      ex, nf,
      AbsorbTargetEvaluator<T>{fluid.x.data(), coupling.sorted_x().data(), s_sorted_.data(),
                               perm.data(), knit.id.data(), coupling.knit_grid().view(),
                               params_.reach, target_.data()},
      "absorb.target");
  std::uint32_t* t = target_.data();
  if (split) {
    // A ghost's choice is its owner's (who sees every knit point within its reach): the
    // choices travel as ids and come back as this rank's indices.
    const std::uint64_t* kid = knit.id.data();
    exec::for_each(
        ex, nf,
        [=] KF_HD(std::size_t j) {
          if (t[j] != kNoTarget)
            t[j] = static_cast<std::uint32_t>(kid[t[j]]);
        },
        "absorb.target_ids");
    split->fluid_ghost_rows(target_);
    const std::uint32_t* local = split->knit_of_id;
    exec::for_each(
        ex, nf,
        [=] KF_HD(std::size_t j) {
          if (t[j] != kNoTarget)
            t[j] = local[t[j]];
        },
        "absorb.target_local");
  }
  // The points this rank owns take in; a ghost's fraction is its owner's.
  const std::size_t takers = split ? split->knit_owned : n;
  fraction_.resize(n);
  exec::for_each(ex, takers,
                 AbsorbFractionEvaluator<T>{knit.x.data(), absorbed_.data(), capacity_.data(),
                                            fluid.m.data(), target_.data(), fluid_cells,
                                            fraction_.data()},
                 "absorb.fraction");
  if (split)
    split->knit_ghost_rows(fraction_);
  const T m_min = params_.min_particle_mass;
  exec::for_each(ex, takers,
                 AbsorbGatherEvaluator<T>{knit.view(), dry_.data(), absorbed_.data(),
                                          fraction_.data(), fluid.x.data(), fluid.v.data(),
                                          fluid.m.data(), target_.data(), fluid_cells, m_min},
                 "absorb.gather");
  keep_.resize(nf);
  const T* fr = fraction_.data();
  T* fm = fluid.m.data();
  const std::uint32_t* own = split ? split->fluid_owned : nullptr;
  Absorbed out;
  if (split) { // counted before the gifts: particles taken whole (low half), in part (high)
    const std::uint64_t both = exec::transform_reduce(
        ex, nf, std::uint64_t(0), exec::SumOp{},
        [=] KF_HD(std::size_t j) -> std::uint64_t {
          if (!own[j] || t[j] == kNoTarget || fr[t[j]] <= T(0))
            return 0;
          return absorbed_amount(fr[t[j]], fm[j], m_min) == fm[j] ? 1 : (std::uint64_t(1) << 32);
        },
        "absorb.count");
    out.removed = both & 0xFFFFFFFFu;
    out.partial = both >> 32;
  }
  Vec3<T>* fa = fluid.a.data();
  std::uint32_t* kp = keep_.data();
  exec::for_each(
      ex, nf,
      [=] KF_HD(std::size_t j) {
        kp[j] = 1u;
        if (own && !own[j]) { // a ghost: its owner gives (the caller removes the ghosts)
          kp[j] = 0u;
          return;
        }
        if (t[j] == kNoTarget || fr[t[j]] <= T(0))
          return;
        const T give = absorbed_amount(fr[t[j]], fm[j], m_min);
        if (give == fm[j]) {
          kp[j] = 0u;
          return;
        }
        // a holds the SPH pair forces over the old mass; the next half kick must apply the same
        // forces to the lighter particle, or the pairs would no longer cancel.
        const T m_old = fm[j];
        fm[j] -= give;
        fa[j] = fa[j] * (m_old / fm[j]);
      },
      "absorb.give");
  if (split) {
    split->knit_ghost_state();
  } else {
    out.removed = fluid.keep_flagged(ex, keep_);
  }
  stats_.absorbed_particles += out.removed;
  return out;
}

template <typename T>
void ConservingAbsorption<T>::diffuse(const exec::Exec& ex, KnitSet<T>& knit, double dt,
                                      const AbsorptionSplit<T>* split) {
  // Split: the owned points move fluid, their ghosts follow after each substep.
  const std::size_t n = split ? split->knit_owned : knit.size();
  if (!(dt > 0) || (!split && (n == 0 || link_other_.size() == 0)))
    return;
  const int sub = static_cast<int>(std::min(1e4, std::ceil(dt / stable_substep_)));
  const T h = static_cast<T>(dt / sub);
  const PoreLinksView<T> links{link_start_.data(), link_other_.data(), link_k_.data(),
                               degree_.data()};
  delta_.resize(n);
  dmom_.resize(n);
  T* a = absorbed_.data();
  const T* d = delta_.data();
  const Vec3<T>* dp = dmom_.data();
  const T* dry = dry_.data();
  const KnitView<T> kv = knit.view();
  // The step's net movement, 1/2 sum |a_end - a_start|, from one reduction after the substeps:
  // a reduction per substep would wait on the device every substep.
  start_.resize(n);
  start_.copy_from(absorbed_, n);
  const T* a0 = start_.data();
  for (int s = 0; s < sub; ++s) {
    exec::for_each(ex, n,
                   DiffusionEvaluator<T>{links, knit.x.data(), knit.v.data(), absorbed_.data(),
                                         capacity_.data(), params_, h, delta_.data(), dmom_.data()},
                   "absorb.diffuse");
    exec::for_each(
        ex, n,
        [=] KF_HD(std::size_t i) {
          const T m_old = kv.m[i];
          a[i] += d[i];
          kv.m[i] = dry[i] + a[i];
          if (kv.handle[i] == kFreePoint)
            kv.v[i] = (kv.v[i] * m_old + dp[i]) * (T(1) / kv.m[i]);
        },
        "absorb.apply");
    if (split)
      split->knit_ghost_state();
  }
  stats_.diffused_mass += 0.5 * exec::transform_reduce(
                                    ex, n, 0.0, exec::SumOp{},
                                    [=] KF_HD(std::size_t i) {
                                      const T q = a[i] - a0[i];
                                      return double(q < T(0) ? -q : q);
                                    },
                                    "absorb.moved");
}

template <typename T>
std::size_t ConservingAbsorption<T>::emit(const exec::Exec& ex, KnitSet<T>& knit,
                                          FluidSet<T>& fluid, std::uint64_t& next_id,
                                          const AbsorptionSplit<T>* split) {
  const std::size_t n = split ? split->knit_owned : knit.size();
  if (!split && n == 0)
    return 0;
  emit_.resize(n);
  offsets_.resize(n);
  {
    const T* a = absorbed_.data();
    const T* c = capacity_.data();
    std::uint32_t* e = emit_.data();
    const T s_emit = params_.emit_saturation, drop = params_.drop_mass;
    exec::for_each(
        ex, n,
        [=] KF_HD(std::size_t i) {
          const T excess = a[i] - s_emit * c[i];
          const T quarter = T(0.25) * c[i];
          e[i] = excess >= (drop < quarter ? drop : quarter) ? 1u : 0u;
        },
        "absorb.emit_count");
  }
  const std::size_t count = exec::exclusive_scan(ex, emit_, offsets_, "absorb.emit_scan");
  std::size_t job = count;
  if (split) {
    // The drops are numbered as one rank numbers them: by their points' ids.
    std::vector<std::uint64_t> ids;
    if (count > 0) { // the emitters' ids to the host (a few a step)
      const auto flags = emit_.to_host();
      const auto id = knit.id.to_host();
      ids.reserve(count);
      for (std::size_t i = 0; i < n; ++i)
        if (flags[i])
          ids.push_back(id[i]);
    }
    job = split->number_drops(ids);
    if (job == 0)
      return 0;
    split->drop_fluid_ghosts();
    drop_id_.assign(ids);
  } else if (count == 0) {
    return 0;
  }
  const std::size_t first = fluid.size();
  fluid.resize(first + count);
  const FluidView<T> f = fluid.view();
  const KnitView<T> p = knit.view();
  const std::uint32_t* e = emit_.data();
  const std::uint32_t* o = offsets_.data();
  const std::uint64_t* place = split ? drop_id_.data() : nullptr;
  T* a = absorbed_.data();
  const T* c = capacity_.data();
  const T* dry = dry_.data();
  const AbsorptionParams<T> prm = params_;
  const std::uint64_t id0 = next_id;
  exec::for_each(
      ex, n,
      [=] KF_HD(std::size_t i) {
        if (!e[i])
          return;
        const std::size_t j = first + o[i];
        // The excess over emit_saturation, at most a full particle: small knit points (less
        // capacity than a particle's mass) emit small drops.
        const T excess = a[i] - prm.emit_saturation * c[i];
        const T drop = excess < prm.drop_mass ? excess : prm.drop_mass;
        a[i] -= drop;
        p.m[i] = dry[i] + a[i];
        f.x[j] = p.x[i] + prm.down * prm.drop_offset;
        f.v[j] = p.v[i]; // the drop leaves with the point's velocity: momentum kept
        f.a[j] = prm.gravity;
        f.m[j] = drop;
        f.rho[j] = prm.rho0;
        f.p[j] = T(0);
        f.drho[j] = T(0);
        f.drho_prev[j] = T(0);
        f.id[j] = id0 + (place ? place[o[i]] : o[i]);
      },
      "absorb.emit");
  if (split)
    split->knit_ghost_state();
  next_id += job;
  stats_.emitted_particles += count;
  return job;
}

template <typename T>
void ConservingAbsorption<T>::restore(const exec::Exec& ex, KnitSet<T>& knit,
                                      const std::vector<T>& absorbed) {
  if (absorbed.size() != mesh_dry_.size() || knit.size() != absorbed.size())
    throw Error("restart: " + std::to_string(absorbed.size()) + " absorbed masses for a knit of " +
                std::to_string(mesh_dry_.size()) + " points");
  whole();
  absorbed_.assign(absorbed);
  const T* a = absorbed_.data();
  const T* dry = dry_.data();
  T* m = knit.m.data();
  exec::for_each(
      ex, knit.size(), [=] KF_HD(std::size_t i) { m[i] = dry[i] + a[i]; }, "absorb.restore");
}

template <typename T>
std::size_t ConservingAbsorption<T>::bytes() const {
  return fraction_.capacity_bytes() + degree_.capacity_bytes() + drop_id_.capacity_bytes() +
         dmom_.capacity_bytes() + start_.capacity_bytes() + dry_.capacity_bytes() +
         absorbed_.capacity_bytes() + capacity_.capacity_bytes() + delta_.capacity_bytes() +
         s_sorted_.capacity_bytes() + link_start_.capacity_bytes() + link_other_.capacity_bytes() +
         target_.capacity_bytes() + keep_.capacity_bytes() + emit_.capacity_bytes() +
         offsets_.capacity_bytes() + link_k_.capacity_bytes();
}

template class ConservingAbsorption<float>;
template class ConservingAbsorption<double>;

} // namespace kf
