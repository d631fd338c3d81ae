#include "kernels/grid/NeighbourList.hpp"

namespace kf {

namespace {

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
    exec::for_each(ex, n,
                   list_detail::ListBuilder<T, AnyPair>{x, x, nullptr, cells, radius2, capacity_,
                                                        count_.data(), list_.data(), AnyPair{}},
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

template class NeighbourList<float>;
template class NeighbourList<double>;

} // namespace kf
