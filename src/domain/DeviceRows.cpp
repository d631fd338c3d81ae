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

void DeviceRows::unpack(std::span<const comm::Column> cols, std::span<const std::size_t> counts,
                        std::span<const unsigned char* const> ins, const std::uint32_t* rows,
                        std::size_t first) {
  const std::size_t row = comm::row_bytes(cols);
  std::size_t total = 0;
  for (std::size_t n : counts)
    total += n;
  if (total == 0 || row == 0)
    return;
  if (!device_messages_)
    packed_.resize(total * row); // the host's messages go up into one run
  batch_.clear();
  std::size_t at = 0;
  for (std::size_t k = 0; k < counts.size(); ++k) {
    const std::size_t bytes = counts[k] * row;
    const unsigned char* src = ins[k];
    if (!device_messages_ && bytes) {
      exec::copy_bytes(packed_.data() + at * row, backend_, ins[k], exec::Backend::Cpu, bytes);
      src = packed_.data() + at * row;
    }
    batch_.push_back({const_cast<unsigned char*>(src), rows ? rows + at : nullptr,
                      rows ? 0 : first + at, counts[k]});
    at += counts[k];
  }
  const auto& c = columns(cols);
  exec::scatter_messages({backend_}, c.data(), c.size(), batch_.data(), batch_.size(),
                         "ranks.unpack");
}

std::shared_ptr<DeviceRows::ListBuffer> DeviceRows::list_buffer(std::size_t n) {
  auto& spare = pool_->spare;
  // The smallest spare that holds n, else the largest (grown).
  const std::size_t want = n * sizeof(std::uint32_t);
  auto pick = spare.end();
  for (auto it = spare.begin(); it != spare.end(); ++it) {
    if (pick == spare.end()) {
      pick = it;
      continue;
    }
    const std::size_t have = it->capacity_bytes(), best = pick->capacity_bytes();
    if (have >= want ? (best < want || have < best) : (best < want && have > best))
      pick = it;
  }
  ListBuffer b(backend_, 0, "ranks.list");
  if (pick != spare.end()) {
    b = std::move(*pick);
    spare.erase(pick);
  }
  b.resize(n);
  const std::weak_ptr<ListPool> pool = pool_;
  return std::shared_ptr<ListBuffer>(new ListBuffer(std::move(b)), [pool](ListBuffer* p) {
    if (const auto live = pool.lock())
      live->spare.push_back(std::move(*p));
    delete p;
  });
}

const std::uint32_t* DeviceRows::device_list(const comm::RowList& list) {
  if (!list.cache) {
    auto copy = list_buffer(list.rows.size());
    copy->assign(list.rows);
    list.cache = copy;
  }
  return static_cast<const exec::DeviceBuffer<std::uint32_t>*>(list.cache.get())->data();
}

template <typename Fill>
comm::RowList DeviceRows::device_only(std::size_t n, Fill fill) {
  auto copy = list_buffer(n);
  fill(copy->data());
  comm::RowList list;
  list.set_cached(n, std::move(copy));
  return list;
}

void DeviceRows::do_remap(comm::RowList& list, comm::Column new_of_old) {
  const std::uint32_t* rows = device_list(list);
  list = device_only(list.size(), [&](std::uint32_t* dst) {
    exec::gather_rows({backend_}, dst, new_of_old.data, rows, list.size(), sizeof(std::uint32_t),
                      "ranks.remap");
  });
}

comm::RowList DeviceRows::do_remapped_range(comm::Column new_of_old, std::size_t first,
                                            std::size_t n) {
  return device_only(n, [&](std::uint32_t* dst) {
    exec::copy_bytes(dst, backend_, static_cast<const std::uint32_t*>(new_of_old.data) + first,
                     backend_, n * sizeof(std::uint32_t));
  });
}

comm::RowList DeviceRows::do_adopt(const std::uint32_t* rows, std::size_t n) {
  return device_only(n, [&](std::uint32_t* dst) {
    exec::copy_bytes(dst, backend_, rows, backend_, n * sizeof(std::uint32_t));
  });
}

void DeviceRows::do_rows_to_host(const comm::RowList& list) {
  list.rows.resize(list.size());
  exec::copy_bytes(list.rows.data(), exec::Backend::Cpu, device_list(list), backend_,
                   list.size() * sizeof(std::uint32_t));
}

void DeviceRows::do_copy_rows(const comm::RowList& list, std::uint32_t* out) {
  exec::copy_bytes(out, backend_, device_list(list), backend_, list.size() * sizeof(std::uint32_t));
}

void DeviceRows::do_gather(std::span<const comm::Column> cols, std::span<const comm::RowList> lists,
                           std::span<unsigned char* const> outs) {
  const std::size_t row = comm::row_bytes(cols);
  std::size_t total = 0;
  for (const comm::RowList& l : lists)
    total += l.size();
  if (total == 0 || row == 0)
    return;
  // One launch for every peer's message (P9: a refresh's launches were its latency); host
  // messages are packed into one device run, then copied down a message at a time.
  if (!device_messages_)
    packed_.resize(total * row);
  batch_.clear();
  std::size_t at = 0;
  for (std::size_t k = 0; k < lists.size(); ++k) {
    const std::size_t n = lists[k].size();
    unsigned char* dst = device_messages_ ? outs[k] : packed_.data() + at * row;
    batch_.push_back({dst, n ? device_list(lists[k]) : nullptr, 0, n});
    at += n;
  }
  const auto& c = columns(cols);
  exec::gather_messages({backend_}, c.data(), c.size(), batch_.data(), batch_.size(), "ranks.pack");
  if (!device_messages_)
    for (std::size_t k = 0; k < lists.size(); ++k)
      if (batch_[k].n)
        exec::copy_bytes(outs[k], exec::Backend::Cpu, batch_[k].packed, backend_,
                         batch_[k].n * row);
}

void DeviceRows::do_scatter(std::span<const comm::Column> cols, const comm::RowList& slots,
                            std::span<const std::size_t> counts,
                            std::span<const unsigned char* const> ins) {
  if (slots.size() == 0)
    return;
  unpack(cols, counts, ins, device_list(slots), 0);
}

void DeviceRows::do_put(std::span<const comm::Column> cols, std::size_t first,
                        std::span<const std::size_t> counts,
                        std::span<const unsigned char* const> ins) {
  unpack(cols, counts, ins, nullptr, first);
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
  compact_flagged(cols);
}

std::size_t DeviceRows::compact_flagged(std::span<const comm::Column> cols) {
  const exec::Exec ex{backend_};
  const std::size_t k = exec::flagged_indices(ex, flags_, offsets_, keep_, "ranks.remove");
  // Through a scratch run: the rows move forward, which in parallel would overwrite unread ones.
  for (const comm::Column& c : cols) {
    packed_.resize(k * c.elem_bytes);
    exec::gather_rows(ex, packed_.data(), c.data, keep_.data(), k, c.elem_bytes, "ranks.remove");
    exec::copy_bytes(c.data, backend_, packed_.data(), backend_, k * c.elem_bytes);
  }
  return k;
}

std::size_t DeviceRows::do_keep_flagged(std::span<const comm::Column> cols, std::size_t n,
                                        const std::uint32_t* keep) {
  // Into the compaction's own buffer (its scan takes one): a device copy of 4 bytes a row.
  flags_.resize(n);
  exec::copy_bytes(flags_.data(), backend_, keep, backend_, n * sizeof(std::uint32_t));
  return compact_flagged(cols);
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
