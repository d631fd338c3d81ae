#include "kernels/knit/SelfContact.hpp"

namespace kf {

template <typename T>
KnitSelfContact<T>::KnitSelfContact(exec::Backend b, const GridGeometry<T>& geo,
                                    const SelfContactParams<T>& params)
    : params_(params), grid_(b, geo), x_(b, 0, "knit.self.x"), v_(b, 0, "knit.self.v"),
      rest_(b, 0, "knit.self.rest"), m_(b, 0, "knit.self.m"), piece_(b, 0, "knit.self.piece"),
      id_(b, 0, "knit.self.id"), x_sorted_at_(b, 0, "knit.self.x_sorted_at"),
      skin2_((geo.cell - T(2) * params.radius) * (geo.cell - T(2) * params.radius)) {
  if (!(geo.cell > T(2) * params.radius))
    throw Error("knit self-collision: grid cell " + std::to_string(double(geo.cell)) +
                " m is not larger than the contact reach 2R = " +
                std::to_string(2.0 * double(params.radius)) + " m");
}

template <typename T>
void KnitSelfContact<T>::update(const exec::Exec& ex, KnitSet<T>& set) {
  const std::size_t n = set.size();
  const bool sort = moved_past_skin(ex, set.x, x_sorted_at_, skin2_, "knit.self.moved");
  const auto& perm = grid_.permutation();
  if (sort) {
    grid_.build(ex, set.x.data(), n);
    ++sorts_;
    x_.resize(n);
    v_.resize(n);
    rest_.resize(n);
    m_.resize(n);
    piece_.resize(n);
    id_.resize(n);
    x_sorted_at_.resize(n);
    x_sorted_at_.copy_from(set.x, n);
    exec::gather(ex, perm, set.x_rest, rest_, "knit.self.gather");
    exec::gather(ex, perm, set.m, m_, "knit.self.gather");
    exec::gather(ex, perm, set.piece, piece_, "knit.self.gather");
    exec::gather(ex, perm, set.id, id_, "knit.self.gather");
  }
  exec::gather(ex, perm, set.x, x_, "knit.self.gather");
  exec::gather(ex, perm, set.v, v_, "knit.self.gather");
}

template <typename T>
SortedKnitView<T> KnitSelfContact<T>::sorted() const {
  return {x_.data(), v_.data(), rest_.data(), m_.data(), piece_.data()};
}

template <typename T>
void KnitSelfContact<T>::add_forces(const exec::Exec& ex, KnitSet<T>& set) const {
  exec::for_each(ex, set.size(),
                 SelfContactEvaluator<T>{set.view(), set.x_rest.data(), set.piece.data(), sorted(),
                                         grid_.view(), params_},
                 "knit.self_contact");
}

template <typename T>
SelfContactStats KnitSelfContact<T>::stats(const exec::Exec& ex, KnitSet<T>& set) const {
  return exec::transform_reduce(
      ex, set.size(), SelfContactStats{}, SelfContactStatsOp{},
      SelfContactStatsEvaluator<T>{set.x.data(), set.x_rest.data(), set.piece.data(), set.id.data(),
                                   sorted(), id_.data(), grid_.view(), params_},
      "knit.self_contact_stats");
}

template <typename T>
std::size_t KnitSelfContact<T>::bytes() const {
  return grid_.bytes() + x_.capacity_bytes() + v_.capacity_bytes() + rest_.capacity_bytes() +
         m_.capacity_bytes() + piece_.capacity_bytes() + id_.capacity_bytes() +
         x_sorted_at_.capacity_bytes();
}

template class KnitSelfContact<float>;
template class KnitSelfContact<double>;

} // namespace kf
