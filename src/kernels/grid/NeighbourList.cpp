#include "kernels/grid/NeighbourList.hpp"

#include "kernels/exec/PeakByLabel.hpp"

namespace kf {

namespace {

struct CountOf {
  const std::uint32_t* count;
  KF_HD std::uint32_t operator()(std::size_t i) const { return count[i]; }
};

} // namespace

template <typename T>
NeighbourList<T>::NeighbourList(exec::Backend b, const char* name)
    : count_(b, 0, exec::joined_label(name, "count")),
      list_(b, 0, exec::joined_label(name, "list")),
      most_dev_(b, 1, exec::joined_label(name, "most")),
      most_read_(b, 1, exec::joined_label(name, "most")) {}

template <typename T>
void NeighbourList<T>::build(const exec::Exec& ex, const Vec3<T>* x, std::size_t n,
                             const CellView<T>& cells, T radius2) {
  build_with(
      ex, n,
      [&](const ListSink& out) {
        return list_detail::ListBuilder<T, Vec3<T>, AnyPair>{x,     x,       nullptr, nullptr,
                                                             cells, radius2, out,     {}};
      },
      "neighbours.build");
}

template <typename T>
bool NeighbourList<T>::fits(const exec::Exec& ex, std::size_t n) {
  start_fit(ex, n);
  return finish_fit();
}

template <typename T>
void NeighbourList<T>::start_fit(const exec::Exec& ex, std::size_t n) {
  exec::transform_reduce_to(ex, n, std::uint32_t(0), exec::MaxOp{}, CountOf{count_.data()},
                            most_dev_.data(), "neighbours.most");
  most_read_.start(most_dev_.data());
}

template <typename T>
bool NeighbourList<T>::finish_fit() {
  if (!most_read_.pending())
    return true;
  most_ = most_read_.wait()[0];
  if (most_ <= capacity_)
    return true;
  capacity_ = capacity_for(most_);
  return false;
}

template class NeighbourList<float>;
template class NeighbourList<double>;

} // namespace kf
