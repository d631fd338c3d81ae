#include "domain/DeviceRows.hpp"

#include "kernels/exec/RowCopy.hpp"

#include <chrono>
#include <memory>

namespace kf {

DeviceRows::DeviceRows(exec::Backend backend)
    : backend_(backend), rows_(backend, 0, "ranks.rows"), packed_(backend, 0, "ranks.packed") {}

void DeviceRows::gather(std::span<const comm::Column> cols, std::span<const std::uint32_t> rows,
                        unsigned char* out) {
  const std::size_t n = rows.size(), bytes = n * comm::row_bytes(cols);
  if (bytes == 0)
    return;
  rows_.assign(rows.data(), n);
  packed_.resize(bytes);
  std::size_t at = 0;
  for (const comm::Column& c : cols) {
    exec::gather_rows({backend_}, packed_.data() + at, c.data, rows_.data(), n, c.elem_bytes,
                      "ranks.pack");
    at += n * c.elem_bytes;
  }
  exec::copy_bytes(out, exec::Backend::Cpu, packed_.data(), backend_, bytes);
}

void DeviceRows::scatter(std::span<const comm::Column> cols, std::span<const std::uint32_t> rows,
                         const unsigned char* in) {
  const std::size_t n = rows.size(), bytes = n * comm::row_bytes(cols);
  if (bytes == 0)
    return;
  rows_.assign(rows.data(), n);
  packed_.assign(in, bytes);
  std::size_t at = 0;
  for (const comm::Column& c : cols) {
    exec::scatter_rows({backend_}, c.data, rows_.data(), packed_.data() + at, n, c.elem_bytes,
                       "ranks.unpack");
    at += n * c.elem_bytes;
  }
}

void DeviceRows::put(std::span<const comm::Column> cols, std::size_t first, std::size_t n,
                     const unsigned char* in) {
  for (const comm::Column& c : cols) {
    if (n)
      exec::copy_bytes(static_cast<unsigned char*>(c.data) + first * c.elem_bytes, backend_, in,
                       exec::Backend::Cpu, n * c.elem_bytes);
    in += n * c.elem_bytes;
  }
}

void DeviceRows::compact(std::span<const comm::Column> cols, std::span<const std::uint32_t> keep) {
  const std::size_t n = keep.size();
  if (n == 0)
    return;
  rows_.assign(keep.data(), n);
  // Through a scratch run: the rows move forward, which in parallel would overwrite unread ones.
  for (const comm::Column& c : cols) {
    packed_.resize(n * c.elem_bytes);
    exec::gather_rows({backend_}, packed_.data(), c.data, rows_.data(), n, c.elem_bytes,
                      "ranks.compact");
    exec::copy_bytes(c.data, backend_, packed_.data(), backend_, n * c.elem_bytes);
  }
}

namespace {
struct AddTime {
  double& sum;
  std::chrono::steady_clock::time_point t0 = std::chrono::steady_clock::now();
  ~AddTime() {
    sum += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  }
};
} // namespace

void TimedRows::gather(std::span<const comm::Column> cols, std::span<const std::uint32_t> rows,
                       unsigned char* out) {
  const AddTime t{seconds_};
  inner_.gather(cols, rows, out);
}
void TimedRows::scatter(std::span<const comm::Column> cols, std::span<const std::uint32_t> rows,
                        const unsigned char* in) {
  const AddTime t{seconds_};
  inner_.scatter(cols, rows, in);
}
void TimedRows::put(std::span<const comm::Column> cols, std::size_t first, std::size_t n,
                    const unsigned char* in) {
  const AddTime t{seconds_};
  inner_.put(cols, first, n, in);
}
void TimedRows::compact(std::span<const comm::Column> cols, std::span<const std::uint32_t> keep) {
  const AddTime t{seconds_};
  inner_.compact(cols, keep);
}

comm::RowCopier& rows_for(exec::Backend backend, std::unique_ptr<DeviceRows>& device) {
  if (backend == exec::Backend::Cpu)
    return comm::host_rows();
  if (!device)
    device = std::make_unique<DeviceRows>(backend);
  return *device;
}

} // namespace kf
