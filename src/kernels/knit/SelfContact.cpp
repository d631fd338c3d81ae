#include "kernels/knit/SelfContact.hpp"
#include "kernels/knit/KnitLanes.hpp"

namespace kf {

template <typename T>
KnitSelfContact<T>::KnitSelfContact(exec::Backend b, const GridGeometry<T>& geo,
                                    const SelfContactParams<T>& params, std::uint32_t list_capacity,
                                    bool windowed)
    : params_(params), whole_(geo),
      grid_(std::in_place, b, windowed ? NeighbourGrid<T>::within(geo, {0, 0, 0}, {0, 0, 0}) : geo,
            1, 0, "knit.self.grid"),
      x_(b, 0, "knit.self.x"), v_(b, 0, "knit.self.v"), rest_(b, 0, "knit.self.rest"),
      m_(b, 0, "knit.self.m"), piece_(b, 0, "knit.self.piece"), id_(b, 0, "knit.self.id"),
      watch_(b, (geo.cell - T(2) * params.radius) / T(2), "knit.self.moved"),
      list_(b, "knit.self.lists"), cell_(geo.cell), list_capacity_(list_capacity) {
  if (!(geo.cell > T(2) * params.radius))
    throw Error("knit self-collision: grid cell " + std::to_string(double(geo.cell)) +
                " m is not larger than the contact reach 2R = " +
                std::to_string(2.0 * double(params.radius)) + " m");
}

template <typename T>
void KnitSelfContact<T>::fit_window(std::array<int, 3> lo, std::array<int, 3> hi) {
  const GridGeometry<T> geo = NeighbourGrid<T>::within(whole_, lo, hi);
  if (!geo.same_cells(grid_->geometry()))
    grid_.emplace(x_.backend(), geo, 1, 0, "knit.self.grid");
}

template <typename T>
void KnitSelfContact<T>::sort(const exec::Exec& ex, KnitSet<T>& set,
                              const exec::DeviceBuffer<Vec3<T>>& at) {
  const std::size_t n = set.size();
  grid_->build(ex, at.data(), n, ties_by_id_ ? set.id.data() : nullptr);
  const auto& perm = this->perm();
  ++sorts_;
  x_.resize(n);
  v_.resize(n);
  rest_.resize(n);
  m_.resize(n);
  piece_.resize(n);
  id_.resize(n);
  watch_.reset(ex, at);
  exec::gather(ex, perm, set.x_rest, rest_, "knit.self.gather");
  exec::gather(ex, perm, set.m, m_, "knit.self.gather");
  exec::gather(ex, perm, set.piece, piece_, "knit.self.gather");
  exec::gather(ex, perm, set.id, id_, "knit.self.gather");
  exec::gather(ex, perm, at, x_, "knit.self.gather");
  exec::gather(ex, perm, set.v, v_, "knit.self.gather");
  list_.build_for(
      ex, at.data(), nullptr, n, x_.data(), grid_->view(), cell_ * cell_, list_capacity_,
      SelfPairAllowed<T>{set.piece.data(), set.x_rest.data(), sorted(), params_.exclusion2});
}

template <typename T>
void KnitSelfContact<T>::restore(const exec::Exec& ex, KnitSet<T>& set,
                                 const typename SkinWatch<T>::State& s) {
  if (s.x0.size() != set.size())
    throw Error("restart: the knit self-contact's sorted positions hold " +
                std::to_string(s.x0.size()) + " points, the knit " + std::to_string(set.size()));
  exec::DeviceBuffer<Vec3<T>> at(ex.backend, 0, "knit.self.restart");
  at.assign(s.x0);
  sort(ex, set, at);
  watch_.restore(s);
  gather_motion(ex, set); // the copies of the points as they are now
}

template <typename T>
void KnitSelfContact<T>::gather_motion(const exec::Exec& ex, KnitSet<T>& set) {
  exec::gather(ex, perm(), set.x, x_, "knit.self.gather");
  exec::gather(ex, perm(), set.v, v_, "knit.self.gather");
}

template <typename T>
void KnitSelfContact<T>::sync(const exec::Exec& ex, KnitSet<T>& set) {
  if (x_.size() != set.size()) {
    sort(ex, set);
  } else if (!(watch_.moved(ex, set.x) <= watch_.skin())) {
    if (!host_checks_)
      ++stale_steps_; // device-watched substeps crossed the skin
    sort(ex, set);
  } else {
    gather_motion(ex, set);
  }
}

template <typename T>
void KnitSelfContact<T>::begin_step(const exec::Exec& ex, KnitSet<T>& set, T motion) {
  const bool device_watched = !host_checks_;
  // A sort might not last the step: every substep then checks on the host (sync).
  host_checks_ = !(T(2) * motion <= watch_.skin());
  bool sorted = false;
  watch_.before_step(ex, set.x, motion, x_.size() != set.size(), [&] {
    if (device_watched && x_.size() == set.size() && !(watch_.bound() <= watch_.skin()))
      ++stale_steps_; // device-watched substeps crossed the skin
    sort(ex, set);
    sorted = true;
  });
  if (!sorted) {
    gather_motion(ex, set);
    // The masses change between steps when the knit absorbs fluid (capillary.model =
    // "conserving"): the pairs take this step's, not those of the last sort (which a restart
    // could not know). Otherwise they are the sort's.
    if (masses_vary_)
      exec::gather(ex, perm(), set.m, m_, "knit.self.gather");
  }
}

template <typename T>
WatchedCopies<T> KnitSelfContact<T>::update_copies(const exec::Exec& ex, KnitSet<T>& set) {
  if (host_checks_) {
    sync(ex, set);
    return {};
  }
  return {&watch_, &perm(), &x_, &v_};
}

template <typename T>
void KnitSelfContact<T>::update(const exec::Exec& ex, KnitSet<T>& set) {
  observe_gather(ex, set.x, set.v, update_copies(ex, set), {}, "knit.self.moved");
}

template <typename T>
SortedKnitView<T> KnitSelfContact<T>::sorted() const {
  return {x_.data(), v_.data(), rest_.data(), m_.data(), piece_.data()};
}

template <typename T>
SelfContactEvaluator<T> KnitSelfContact<T>::evaluator(KnitSet<T>& set) const {
  const T margin = cell_ - T(2) * params_.radius; // a walk of the cells holds up to it
  return {set.view(),
          set.x_rest.data(),
          set.piece.data(),
          sorted(),
          grid_->view(),
          params_,
          list_.view(),
          watch_.moved2(),
          watch_.skin2(),
          margin * margin,
          static_cast<std::uint32_t>(x_.size())};
}

template <typename T>
void KnitSelfContact<T>::add_forces(const exec::Exec& ex, KnitSet<T>& set) const {
  exec::for_each_lanes<kKnitLanes>(ex, active(set), evaluator(set), "knit.self_contact");
}

template <typename T>
SelfContactStats KnitSelfContact<T>::stats(const exec::Exec& ex, KnitSet<T>& set) const {
  return exec::transform_reduce(
      ex, active(set), SelfContactStats{}, SelfContactStatsOp{},
      SelfContactStatsEvaluator<T>{set.x.data(), set.x_rest.data(), set.piece.data(), set.id.data(),
                                   sorted(), id_.data(), grid_->view(), params_},
      "knit.self_contact_stats");
}

template <typename T>
std::size_t KnitSelfContact<T>::bytes() const {
  return grid_->bytes() + list_.bytes() + x_.capacity_bytes() + v_.capacity_bytes() +
         rest_.capacity_bytes() + m_.capacity_bytes() + piece_.capacity_bytes() +
         id_.capacity_bytes() + watch_.bytes();
}

template class KnitSelfContact<float>;
template class KnitSelfContact<double>;

} // namespace kf
