#include "domain/DeviceRows.hpp"

#include "kernels/exec/RowCopy.hpp"

#include <algorithm>
#include <memory>

namespace kf {

DeviceRows::DeviceRows(exec::Backend backend, bool device_messages)
    : backend_(backend), device_messages_(device_messages), rows_(backend, 0, "ranks.rows"),
      flags_(backend, 0, "ranks.flags"), offsets_(backend, 0, "ranks.offsets"),
      keep_(backend, 0, "ranks.keep"), packed_(backend, 0, "ranks.packed") {}

const std::vector<exec::RowColumn>& DeviceRows::columns(std::span<const comm::Column> cols) {
  columns_.clear();
  for (const comm::Column& c : cols)
    columns_.push_back({c.data, c.elem_bytes});
  return columns_;
}

void DeviceRows::pack(std::span<const comm::Column> cols, const std::uint32_t* rows, std::size_t n,
                      unsigned char* dst) {
  // One launch for every column of a message: a refresh's launches were its latency (P5 stage 8).
  const auto& c = columns(cols);
  exec::gather_columns({backend_}, dst, c.data(), c.size(), rows, n, "ranks.pack");
}

void DeviceRows::unpack(std::span<const comm::Column> cols, const std::uint32_t* rows,
                        std::size_t n, const unsigned char* in) {
  const std::size_t bytes = n * comm::row_bytes(cols);
  const unsigned char* src = in;
  if (!device_messages_) {
    packed_.assign(in, bytes);
    src = packed_.data();
  }
  const auto& c = columns(cols);
  exec::scatter_columns({backend_}, c.data(), c.size(), rows, src, n, "ranks.unpack");
}

const std::uint32_t* DeviceRows::device_list(const comm::RowList& list) {
  if (!list.cache) {
    auto copy = std::make_shared<exec::DeviceBuffer<std::uint32_t>>(backend_, 0, "ranks.list");
    copy->assign(list.rows);
    list.cache = copy;
  }
  return static_cast<const exec::DeviceBuffer<std::uint32_t>*>(list.cache.get())->data();
}

void DeviceRows::do_gather(std::span<const comm::Column> cols, std::span<const std::uint32_t> rows,
                           unsigned char* out) {
  if (!device_messages_) {
    do_gather_to_host(cols, rows, out);
    return;
  }
  if (rows.empty())
    return;
  rows_.assign(rows.data(), rows.size());
  pack(cols, rows_.data(), rows.size(), out);
}

void DeviceRows::do_gather_list(std::span<const comm::Column> cols, const comm::RowList& list,
                                unsigned char* out) {
  const std::size_t n = list.size(), bytes = n * comm::row_bytes(cols);
  if (bytes == 0)
    return;
  const std::uint32_t* rows = device_list(list);
  if (device_messages_) {
    pack(cols, rows, n, out);
    return;
  }
  packed_.resize(bytes);
  pack(cols, rows, n, packed_.data());
  exec::copy_bytes(out, exec::Backend::Cpu, packed_.data(), backend_, bytes);
}

void DeviceRows::do_gather_to_host(std::span<const comm::Column> cols,
                                   std::span<const std::uint32_t> rows, unsigned char* out) {
  const std::size_t bytes = rows.size() * comm::row_bytes(cols);
  if (bytes == 0)
    return;
  rows_.assign(rows.data(), rows.size());
  packed_.resize(bytes);
  pack(cols, rows_.data(), rows.size(), packed_.data());
  exec::copy_bytes(out, exec::Backend::Cpu, packed_.data(), backend_, bytes);
}

void DeviceRows::do_scatter_list(std::span<const comm::Column> cols, const comm::RowList& list,
                                 std::size_t first, std::size_t n, const unsigned char* in) {
  if (n == 0 || comm::row_bytes(cols) == 0)
    return;
  unpack(cols, device_list(list) + first, n, in);
}

void DeviceRows::do_put(std::span<const comm::Column> cols, std::size_t first, std::size_t n,
                        const unsigned char* in) {
  for (const comm::Column& c : cols) {
    if (n)
      exec::copy_bytes(static_cast<unsigned char*>(c.data) + first * c.elem_bytes, backend_, in,
                       device_messages_ ? backend_ : exec::Backend::Cpu, n * c.elem_bytes);
    in += n * c.elem_bytes;
  }
}

void DeviceRows::do_remove(std::span<const comm::Column> cols, std::size_t n,
                           std::span<const std::uint32_t> gone) {
  if (gone.empty() || n == 0)
    return;
  // The rows that stay, found on the device from the few that go.
  const exec::Exec ex{backend_};
  flags_.resize(n);
  rows_.assign(gone.data(), gone.size());
  exec::flag_all_but(ex, flags_.data(), n, rows_.data(), gone.size(), "ranks.remove");
  const std::size_t k = exec::flagged_indices(ex, flags_, offsets_, keep_, "ranks.remove");
  // Through a scratch run: the rows move forward, which in parallel would overwrite unread ones.
  for (const comm::Column& c : cols) {
    packed_.resize(k * c.elem_bytes);
    exec::gather_rows(ex, packed_.data(), c.data, keep_.data(), k, c.elem_bytes, "ranks.remove");
    exec::copy_bytes(c.data, backend_, packed_.data(), backend_, k * c.elem_bytes);
  }
}

unsigned char* DeviceRows::do_message(std::size_t slot, std::size_t bytes) {
  if (device_messages_) {
    while (device_messages_slots_.size() <= slot)
      device_messages_slots_.emplace_back(backend_, 0, "ranks.message");
    auto& m = device_messages_slots_[slot];
    if (m.size() < bytes)
      m.resize(bytes);
    return m.data();
  }
  while (messages_.size() <= slot)
    messages_.emplace_back(backend_);
  Staging& m = messages_[slot];
  if (m.bytes < bytes) {
    // Grown by half again: a halo's size drifts a little from one rebuild to the next.
    const std::size_t want = std::max(bytes, m.bytes + m.bytes / 2);
    exec::free_host_staging(backend_, m.p);
    m.p = nullptr;
    m.bytes = 0;
    m.p = exec::alloc_host_staging(backend_, want, "ranks.message");
    m.bytes = want;
  }
  return static_cast<unsigned char*>(m.p);
}

std::unique_ptr<comm::RowCopier> make_rows(exec::Backend backend, bool device_messages) {
  if (backend == exec::Backend::Cpu)
    return std::make_unique<comm::RowCopier>();
  return std::make_unique<DeviceRows>(backend, device_messages);
}

} // namespace kf
