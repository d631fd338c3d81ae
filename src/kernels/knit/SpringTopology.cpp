#include "kernels/knit/SpringTopology.hpp"

#include "core/Error.hpp"
#include "kernels/knit/LocalRows_K.hpp"
#include "kernels/knit/PointRows.hpp"

#include <algorithm>
#include <numeric>
#include <string>

namespace kf {

template <typename T>
SpringTopology<T>::SpringTopology(exec::Backend b)
    : count_(b, 0, "knit.springs.count"), entry_(b, 0, "knit.springs.entry"),
      by_kind_(kSpringKinds, 0) {}

namespace {

// The rows of a spring list: each row's count, and its entries where `layout(rows, width)` puts
// them (each row in the list's order); row_of[p] is point p's row, or kAbsentPoint for a point
// without one (its springs are passed over). Rejects i == j and indices >= n.
// `table(size)` gives the entries' storage (zeroed), written in place: a large knit's table is
// its largest (16 bytes an entry, ~22 a point), and a copy of it would double the host's peak.
template <typename T, typename Layout, typename Table>
void spring_rows(const std::vector<Spring>& springs, const std::vector<std::uint32_t>& row_of,
                 std::size_t n_rows, Layout layout, Table table, std::vector<std::uint32_t>& count,
                 std::vector<std::size_t>& by_kind, std::uint32_t& width) {
  const std::size_t n_points = row_of.size();
  count.assign(n_rows, 0);
  by_kind.assign(kSpringKinds, 0);
  for (const Spring& s : springs) {
    if (s.i == s.j || s.i >= n_points || s.j >= n_points)
      throw Error("spring " + std::to_string(s.i) + "-" + std::to_string(s.j) +
                  " is not between two distinct points of " + std::to_string(n_points));
    for (const std::uint32_t p : {s.i, s.j})
      if (row_of[p] != kAbsentPoint)
        ++count[row_of[p]];
    ++by_kind[static_cast<std::size_t>(s.kind)];
  }
  for (std::uint32_t c : count)
    width = std::max(width, c);
  const RowLayout rows = layout(n_rows, width);
  SpringEntry<T>* entry = table(std::size_t(width) * n_rows);
  std::vector<std::uint32_t> fill(n_rows, 0);
  // Member by member: in double an entry has 4 bytes of padding, zeroed with the table (both
  // tables come zeroed byte by byte) and left so; a whole-struct store may copy a temporary's
  // undefined padding, which the copy to the backend then reads (Valgrind's copy check).
  auto put = [&](std::uint32_t a, std::uint32_t b, const Spring& s) {
    const std::uint32_t r = row_of[a];
    if (r == kAbsentPoint)
      return;
    SpringEntry<T>& e = entry[rows.at(fill[r]++, r)];
    e.other = b;
    e.rest = static_cast<T>(s.rest);
    e.k = static_cast<T>(s.k);
    e.c = static_cast<T>(s.c);
  };
  for (const Spring& s : springs) {
    put(s.i, s.j, s);
    put(s.j, s.i, s);
  }
}

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
void SpringTopology<T>::build(const std::vector<Spring>& springs, std::size_t n_points) {
  std::vector<std::uint32_t> count, row_of(n_points);
  std::iota(row_of.begin(), row_of.end(), 0u);
  // Zeroed byte by byte, padding too, in one pass (as host_rows' table): plain host memory here.
  exec::HostReadable<SpringEntry<T>> entry;
  const exec::Backend b = count_.backend();
  width_ = 0;
  spring_rows<T>(
      springs, row_of, n_points,
      [b](std::size_t n, std::uint32_t w) { return RowLayout::for_backend(b, n, w); },
      [&entry](std::size_t k) {
        entry = exec::HostReadable<SpringEntry<T>>(exec::Backend::Cpu, k, "knit.springs.table");
        return entry.data();
      },
      count, by_kind_, width_);
  count_.assign(count);
  entry_.assign(entry.data(), entry.size());
  springs_ = springs.size();
}

template <typename T>
typename SpringTopology<T>::HostRows
SpringTopology<T>::host_rows(exec::Backend b, const std::vector<Spring>& springs,
                             std::size_t n_points, const std::vector<std::uint64_t>& ids,
                             std::uint32_t width) {
  std::vector<std::uint32_t> count;
  const std::vector<std::uint32_t> row_of = rows_of_points(ids, n_points, "spring rows");
  HostRows m;
  m.width = width;
  spring_rows<T>(
      springs, row_of, ids.size(),
      [](std::size_t, std::uint32_t w) {
        return RowLayout{1, w};
      },
      [&m, b](std::size_t k) {
        m.entry = exec::HostReadable<SpringEntry<T>>(b, k, "knit.rank.springs.entry");
        return m.entry.data();
      },
      count, m.by_kind, m.width);
  m.count = exec::HostReadable<std::uint32_t>(b, count, "knit.rank.springs.count");
  m.springs = springs.size();
  return m;
}

template <typename T>
void SpringTopology<T>::localize(const exec::Exec& ex, const HostRows& from,
                                 const std::uint32_t* local_of_id, std::size_t owned) {
  if (from.points() < owned)
    throw Error("knit springs: rows for " + std::to_string(from.points()) + " points, " +
                std::to_string(owned) + " owned");
  width_ = from.width; // before rows(): the CPU's rows are width_ apart
  // Written anew below (a row's slots past its count never): grown without copying them.
  count_.resize_snug_discarding(owned);
  entry_.resize_snug_discarding(std::size_t(width_) * owned);
  exec::for_each(ex, owned,
                 LocalRowGather<SpringEntry<T>, OtherEndLocal<T>>{from.count.data(),
                                                                  from.entry.data(),
                                                                  from.rows(),
                                                                  rows(),
                                                                  count_.data(),
                                                                  entry_.data(),
                                                                  {{local_of_id}}},
                 "knit.springs.localize");
  springs_ = from.springs;
  by_kind_ = from.by_kind;
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
