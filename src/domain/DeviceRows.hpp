#pragma once
// The ranks' halo and migration rows on a device backend (comm::RowCopier): the columns are
// device memory; a message is packed on the device (one gather kernel a column) and copied to
// the host buffer the MPI transport sends, and a received one copied up and scattered, so only
// the rows that move cross the bus.
#include "comm/RowCopier.hpp"
#include "kernels/exec/DeviceBuffer.hpp"

#include <memory>

namespace kf {

class DeviceRows final : public comm::RowCopier {
public:
  explicit DeviceRows(exec::Backend backend);

  void gather(std::span<const comm::Column> cols, std::span<const std::uint32_t> rows,
              unsigned char* out) override;
  void scatter(std::span<const comm::Column> cols, std::span<const std::uint32_t> rows,
               const unsigned char* in) override;
  void put(std::span<const comm::Column> cols, std::size_t first, std::size_t n,
           const unsigned char* in) override;
  void compact(std::span<const comm::Column> cols, std::span<const std::uint32_t> keep) override;

private:
  exec::Backend backend_;
  exec::DeviceBuffer<std::uint32_t> rows_;
  exec::DeviceBuffer<unsigned char> packed_;
};

/// Another copier, its time added to `seconds` (the split's packing and unpacking).
class TimedRows final : public comm::RowCopier {
public:
  TimedRows(comm::RowCopier& inner, double& seconds) : inner_(inner), seconds_(seconds) {}
  void gather(std::span<const comm::Column> cols, std::span<const std::uint32_t> rows,
              unsigned char* out) override;
  void scatter(std::span<const comm::Column> cols, std::span<const std::uint32_t> rows,
               const unsigned char* in) override;
  void put(std::span<const comm::Column> cols, std::size_t first, std::size_t n,
           const unsigned char* in) override;
  void compact(std::span<const comm::Column> cols, std::span<const std::uint32_t> keep) override;

private:
  comm::RowCopier& inner_;
  double& seconds_;
};

/// The copier for a backend's buffers: the host's on the CPU.
comm::RowCopier& rows_for(exec::Backend backend, std::unique_ptr<DeviceRows>& device);

} // namespace kf
