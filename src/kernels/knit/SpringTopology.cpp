#include "kernels/knit/SpringTopology.hpp"

#include "core/Error.hpp"

#include <string>

namespace kf {

template <typename T>
SpringTopology<T>::SpringTopology(exec::Backend b)
    : start_(b, 0, "knit.springs.start"), other_(b, 0, "knit.springs.other"),
      rest_(b, 0, "knit.springs.rest"), k_(b, 0, "knit.springs.k"), c_(b, 0, "knit.springs.c"),
      by_kind_(kSpringKinds, 0) {}

template <typename T>
void SpringTopology<T>::build(const std::vector<Spring>& springs, std::size_t n_points) {
  std::vector<std::uint32_t> start(n_points + 1, 0);
  by_kind_.assign(kSpringKinds, 0);
  for (const Spring& s : springs) {
    if (s.i == s.j || s.i >= n_points || s.j >= n_points)
      throw Error("spring " + std::to_string(s.i) + "-" + std::to_string(s.j) +
                  " is not between two distinct points of " + std::to_string(n_points));
    ++start[s.i + 1];
    ++start[s.j + 1];
    ++by_kind_[static_cast<std::size_t>(s.kind)];
  }
  for (std::size_t i = 0; i < n_points; ++i)
    start[i + 1] += start[i];
  const std::size_t entries = start[n_points];
  std::vector<std::uint32_t> other(entries), fill(start.begin(), start.end() - 1);
  std::vector<T> rest(entries), k(entries), c(entries);
  auto put = [&](std::uint32_t a, std::uint32_t b, const Spring& s) {
    const std::uint32_t e = fill[a]++;
    other[e] = b;
    rest[e] = static_cast<T>(s.rest);
    k[e] = static_cast<T>(s.k);
    c[e] = static_cast<T>(s.c);
  };
  for (const Spring& s : springs) {
    put(s.i, s.j, s);
    put(s.j, s.i, s);
  }
  start_.assign(start);
  other_.assign(other);
  rest_.assign(rest);
  k_.assign(k);
  c_.assign(c);
  springs_ = springs.size();
}

template <typename T>
SpringView<T> SpringTopology<T>::view() const {
  return {start_.data(), other_.data(), rest_.data(),
          k_.data(),     c_.data(),     start_.size() ? start_.size() - 1 : 0};
}

template <typename T>
std::size_t SpringTopology<T>::bytes() const {
  return start_.capacity_bytes() + other_.capacity_bytes() + rest_.capacity_bytes() +
         k_.capacity_bytes() + c_.capacity_bytes();
}

template class SpringTopology<float>;
template class SpringTopology<double>;

} // namespace kf
