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

template <typename U>
comm::MigrationColumn resizable(exec::DeviceBuffer<U>& b) {
  return {sizeof(U), [&b](std::size_t k) {
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

/// Both views of the same buffers, listed once.
struct ExchangeColumns {
  std::vector<comm::Column> halo;
  std::vector<comm::MigrationColumn> migration;
  template <typename... U>
  static ExchangeColumns of(exec::DeviceBuffer<U>&... b) {
    return {{column(b)...}, {resizable(b)...}};
  }
};

} // namespace kf
