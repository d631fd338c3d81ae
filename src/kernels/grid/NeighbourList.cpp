#include "kernels/grid/NeighbourList.hpp"

namespace kf {

namespace {

/// Writes four indices with one 16-byte store on the GPU (p is 16-byte aligned).
KF_HD KF_INLINE void store4(std::uint32_t* p, std::uint32_t a, std::uint32_t b, std::uint32_t c,
                            std::uint32_t d) {
#if defined(__CUDA_ARCH__)
  *reinterpret_cast<uint4*>(p) = make_uint4(a, b, c, d);
#else
  p[0] = a;
  p[1] = b;
  p[2] = c;
  p[3] = d;
#endif
}

/// Appends i's neighbours while they fit; counts all of them (a count over the capacity asks
/// for a larger one and another build). Neighbours are held in registers and written four at a
/// time: lanes of a warp find neighbours at different candidates, so single-index stores each
/// became their own memory transaction, and the build cost 2.5x a density pass (measured).
template <typename T>
struct ListBuilder {
  const Vec3<T>* q;            // query points
  const Vec3<T>* x;            // candidates, in `cells`' order
  const std::uint32_t* active; // nullptr: every query point; else those with active[i] != 0
  CellView<T> cells;
  T radius2;
  std::size_t capacity; // a multiple of 4
  std::uint32_t* count;
  std::uint32_t* list;

  KF_HD void operator()(std::size_t i) const {
    if (active && !active[i]) {
      count[i] = 0;
      return;
    }
    const Vec3<T> xi = q[i];
    std::uint32_t c = 0, b0 = 0, b1 = 0, b2 = 0;
    std::uint32_t* row = list + i * capacity;
    cells.for_each_candidate(xi, [&](std::uint32_t j) {
      if (!(norm2(xi - x[j]) < radius2))
        return;
      switch (c & 3u) {
      case 0:
        b0 = j;
        break;
      case 1:
        b1 = j;
        break;
      case 2:
        b2 = j;
        break;
      default:
        if (c < capacity)
          store4(row + (c - 3), b0, b1, b2, j);
      }
      ++c;
    });
    // The last 1-3 neighbours.
    const std::uint32_t tail = c & ~3u;
    if (tail < capacity) {
      if (tail + 0 < c)
        row[tail + 0] = b0;
      if (tail + 1 < c)
        row[tail + 1] = b1;
      if (tail + 2 < c)
        row[tail + 2] = b2;
    }
    count[i] = c;
  }
};

struct CountOf {
  const std::uint32_t* count;
  KF_HD std::uint32_t operator()(std::size_t i) const { return count[i]; }
};

} // namespace

template <typename T>
NeighbourList<T>::NeighbourList(exec::Backend b)
    : count_(b, 0, "neighbours.count"), list_(b, 0, "neighbours.list") {}

template <typename T>
void NeighbourList<T>::build(const exec::Exec& ex, const Vec3<T>* x, std::size_t n,
                             const CellView<T>& cells, T radius2) {
  count_.resize(n);
  if (capacity_ == 0)
    capacity_ = 32;
  for (;;) {
    list_.resize(std::size_t(capacity_) * n);
    // One thread per particle (for_each), then the largest count: a reduction's fixed grid
    // of strided threads would walk the candidates with a third of the GPU's threads.
    exec::for_each(
        ex, n,
        ListBuilder<T>{x, x, nullptr, cells, radius2, capacity_, count_.data(), list_.data()},
        "neighbours.build");
    const std::uint32_t* c = count_.data();
    most_ = exec::transform_reduce(ex, n, std::uint32_t(0), exec::MaxOp{}, CountOf{c},
                                   "neighbours.most");
    if (most_ <= capacity_)
      return;
    // Room for the density to rise before the next growth; a multiple of 4 (16-byte rows).
    capacity_ = (most_ + most_ / 4 + 4 + 3) / 4 * 4;
  }
}

template <typename T>
void NeighbourList<T>::build_for(const exec::Exec& ex, const Vec3<T>* q,
                                 const std::uint32_t* active, std::size_t n, const Vec3<T>* x,
                                 const CellView<T>& cells, T radius2, std::uint32_t capacity) {
  capacity_ = (capacity + 3) / 4 * 4;
  count_.resize(n);
  list_.resize(std::size_t(capacity_) * n);
  exec::for_each(
      ex, n, ListBuilder<T>{q, x, active, cells, radius2, capacity_, count_.data(), list_.data()},
      "neighbours.build_for");
}

template class NeighbourList<float>;
template class NeighbourList<double>;

} // namespace kf
