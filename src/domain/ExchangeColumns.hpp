#pragma once
// How the split's exchanges see a particle set's buffers (RankExchange, KnitHalo): as columns of
// bytes that a halo refresh writes into, or that a migration resizes in place (on the buffers'
// backend: a device backend's are read and written through DeviceRows), and as host values
// where the split still decides on the host (the start, re-partitions, the knit's ghosts; a
// rebuild's owners and ghosts are chosen on the backend: RankSelector).
#include "comm/HaloExchange.hpp"
#include "kernels/exec/DeviceBuffer.hpp"

#include <span>
#include <vector>

namespace kf {

template <typename U>
comm::Column column(exec::DeviceBuffer<U>& b) {
  return {b.data(), sizeof(U)};
}

/// snug: grows by a sixteenth where it grows (DeviceBuffer::resize_snug), for columns whose owner
/// keeps them fitted to its points (the knit's); else geometrically.
template <typename U>
comm::MigrationColumn resizable(exec::DeviceBuffer<U>& b, bool snug = false) {
  return {sizeof(U), [&b, snug](std::size_t k) {
            if (snug)
              b.resize_snug(k);
            else
              b.resize(k);
            return reinterpret_cast<unsigned char*>(b.data());
          }};
}

/// The first n elements of a buffer on the host: the buffer itself on the CPU, a copy of them
/// from a device.
template <typename U>
class HostValues {
public:
  HostValues(const exec::DeviceBuffer<U>& b, std::size_t n) {
    if (b.backend() == exec::Backend::Cpu) {
      p_ = b.data();
    } else {
      copy_.resize(n);
      if (n)
        exec::copy_bytes(copy_.data(), exec::Backend::Cpu, b.data(), b.backend(), n * sizeof(U));
      p_ = copy_.data();
    }
    n_ = n;
  }
  explicit HostValues(const exec::DeviceBuffer<U>& b) : HostValues(b, b.size()) {}
  const U& operator[](std::size_t i) const { return p_[i]; }
  std::span<const U> span() const { return {p_, n_}; }
  std::size_t size() const { return n_; }

private:
  const U* p_ = nullptr;
  std::size_t n_ = 0;
  std::vector<U> copy_;
};

/// Both views of the same buffers, listed once (their migrations grow them snugly).
struct ExchangeColumns {
  std::vector<comm::Column> halo;
  std::vector<comm::MigrationColumn> migration;
  template <typename... U>
  static ExchangeColumns of(exec::DeviceBuffer<U>&... b) {
    return {{column(b)...}, {resizable(b, true)...}};
  }
  template <typename U>
  void add(exec::DeviceBuffer<U>& b) {
    halo.push_back(column(b));
    migration.push_back(resizable(b, true));
  }
};

} // namespace kf
