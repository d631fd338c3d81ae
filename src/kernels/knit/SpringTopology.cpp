#include "kernels/knit/SpringTopology.hpp"

#include "core/Error.hpp"
#include "kernels/knit/LocalRows_K.hpp"

#include <algorithm>
#include <string>

namespace kf {

template <typename T>
SpringTopology<T>::SpringTopology(exec::Backend b)
    : count_(b, 0, "knit.springs.count"), entry_(b, 0, "knit.springs.entry"),
      by_kind_(kSpringKinds, 0) {}

template <typename T>
void SpringTopology<T>::build(const std::vector<Spring>& springs, std::size_t n_points) {
  std::vector<std::uint32_t> count(n_points, 0);
  by_kind_.assign(kSpringKinds, 0);
  for (const Spring& s : springs) {
    if (s.i == s.j || s.i >= n_points || s.j >= n_points)
      throw Error("spring " + std::to_string(s.i) + "-" + std::to_string(s.j) +
                  " is not between two distinct points of " + std::to_string(n_points));
    ++count[s.i];
    ++count[s.j];
    ++by_kind_[static_cast<std::size_t>(s.kind)];
  }
  std::uint32_t width = 0;
  for (std::uint32_t c : count)
    width = std::max(width, c);
  const RowLayout rows = RowLayout::for_backend(count_.backend(), n_points, width);
  std::vector<SpringEntry<T>> entry(std::size_t(width) * n_points);
  std::vector<std::uint32_t> fill(n_points, 0);
  auto put = [&](std::uint32_t a, std::uint32_t b, const Spring& s) {
    entry[rows.at(fill[a]++, a)] = {b, static_cast<T>(s.rest), static_cast<T>(s.k),
                                    static_cast<T>(s.c)};
  };
  for (const Spring& s : springs) {
    put(s.i, s.j, s);
    put(s.j, s.i, s);
  }
  count_.assign(count);
  entry_.assign(entry);
  springs_ = springs.size();
  width_ = width;
}

namespace {

// A spring entry with its other end made local.
template <typename T>
struct OtherEndLocal {
  LocalOfId local;
  KF_HD KF_INLINE SpringEntry<T> operator()(SpringEntry<T> s) const {
    s.other = local(s.other);
    return s;
  }
};

} // namespace

template <typename T>
void SpringTopology<T>::localize(const exec::Exec& ex, const SpringTopology& mesh,
                                 const std::uint64_t* id, const std::uint32_t* local_of_id,
                                 std::size_t owned, std::size_t n) {
  width_ = mesh.width_; // before rows(): the CPU's rows are width_ apart
  count_.resize(n);
  entry_.resize(std::size_t(width_) * n);
  exec::for_each(ex, n,
                 LocalRowGather<SpringEntry<T>, OtherEndLocal<T>>{mesh.count_.data(),
                                                                  mesh.entry_.data(),
                                                                  mesh.rows(),
                                                                  id,
                                                                  owned,
                                                                  rows(),
                                                                  count_.data(),
                                                                  entry_.data(),
                                                                  {{local_of_id}}},
                 "knit.springs.localize");
  springs_ = mesh.springs_;
  by_kind_ = mesh.by_kind_;
}

template <typename T>
SpringView<T> SpringTopology<T>::view() const {
  return {count_.data(), entry_.data(), rows()};
}

template <typename T>
std::size_t SpringTopology<T>::bytes() const {
  return count_.capacity_bytes() + entry_.capacity_bytes();
}

template class SpringTopology<float>;
template class SpringTopology<double>;

} // namespace kf
