#include "kernels/grid/TransposedList.hpp"

#include "core/Error.hpp"
#include "kernels/exec/PeakByLabel.hpp"

#include <string>

namespace kf {

template <typename T>
TransposedList<T>::TransposedList(exec::Backend b, const char* name)
    : count_(b, 0, exec::joined_label(name, "count")),
      unsorted_(b, 0, exec::joined_label(name, "unsorted")),
      unsorted_row_(b, 0, exec::joined_label(name, "unsorted")),
      list_(b, 0, exec::joined_label(name, "list")) {}

template <typename T>
void TransposedList<T>::build(const exec::Exec& ex, const ListView<T>& src,
                              const std::uint32_t* active, const std::uint32_t* map, std::size_t n,
                              std::uint32_t capacity, const std::uint32_t* sources) {
  if (std::uint64_t(src.capacity) * src.rows > 0xFFFFFFFFull)
    throw Error("transposed list: the source list's " + std::to_string(src.capacity) + " x " +
                std::to_string(src.rows) + " slots do not fit in 32-bit entries");
  capacity_ = (capacity + kListGroup - 1) / kListGroup * kListGroup;
  rows_ = n;
  count_.resize(n + 1); // the last word: incomplete()
  unsorted_.resize(std::size_t(capacity_) * n);
  unsorted_row_.resize(std::size_t(capacity_) * n);
  list_.resize(std::size_t(capacity_) * n);
  exec::fill(ex, count_, 0u, "transpose.count");
  const ListSink unsorted{count_.data(), unsorted_.data(), capacity_, n};
  // Lanes a source row as the coupling's fluid side reads it: rows of up to ~100 entries.
  exec::for_each_lanes<8>(ex, src.rows,
                          transpose_detail::Fill<T>{src, active, map, count_.data(),
                                                    count_.data() + n, sources, unsorted,
                                                    unsorted_row_.data()},
                          "transpose.fill");
  // 16 lanes a row: each step of the rank sort's inner loop reads one key for all of a row's
  // lanes. The pour's rows (~40 pairs, up to ~100) took 26.6 / 17.3 / 15.4 us a step with 4 / 8
  // / 16 lanes (H200; 32 lanes, with the key computed from the slot, 29).
  exec::for_each_lanes<16>(
      ex, n,
      transpose_detail::Sort<T>{
          count_.data(), ListView<T>{count_.data(), unsorted_.data(), capacity_, n},
          unsorted_row_.data(), ListSink{count_.data(), list_.data(), capacity_, n}},
      "transpose.sort");
}

template class TransposedList<float>;
template class TransposedList<double>;

} // namespace kf
