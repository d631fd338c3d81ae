#pragma once
// How the split's exchanges see a particle set's buffers (RankExchange, KnitHalo): as columns of
// bytes that a halo refresh writes into, or that a migration resizes in place. Host memory: the
// CPU backend's buffers.
#include "comm/HaloExchange.hpp"
#include "kernels/exec/DeviceBuffer.hpp"

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
