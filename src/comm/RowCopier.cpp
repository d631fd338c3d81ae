#include "comm/RowCopier.hpp"

#include "core/Error.hpp"

#include <algorithm>
#include <chrono>
#include <cstring>

namespace kf::comm {

namespace {
void gather_one(std::span<const Column> cols, std::span<const std::uint32_t> rows,
                unsigned char* out) {
  for (const Column& c : cols) {
    const auto* src = static_cast<const unsigned char*>(c.data);
    for (std::uint32_t i : rows) {
      std::memcpy(out, src + std::size_t(i) * c.elem_bytes, c.elem_bytes);
      out += c.elem_bytes;
    }
  }
}
} // namespace

void RowCopier::do_gather(std::span<const Column> cols, std::span<const RowList> lists,
                          std::span<unsigned char* const> outs) {
  for (std::size_t k = 0; k < lists.size(); ++k)
    gather_one(cols, rows_of(lists[k]), outs[k]);
}

void RowCopier::do_scatter(std::span<const Column> cols, const RowList& slots,
                           std::span<const std::size_t> counts,
                           std::span<const unsigned char* const> ins) {
  std::size_t first = 0;
  for (std::size_t k = 0; k < counts.size(); ++k) {
    const std::span<const std::uint32_t> rows(rows_of(slots).data() + first, counts[k]);
    const unsigned char* in = ins[k];
    for (const Column& c : cols) {
      auto* dst = static_cast<unsigned char*>(c.data);
      for (std::uint32_t i : rows) {
        std::memcpy(dst + std::size_t(i) * c.elem_bytes, in, c.elem_bytes);
        in += c.elem_bytes;
      }
    }
    first += counts[k];
  }
}

void RowCopier::do_put(std::span<const Column> cols, std::size_t first,
                       std::span<const std::size_t> counts,
                       std::span<const unsigned char* const> ins) {
  for (std::size_t k = 0; k < counts.size(); ++k) {
    const std::size_t n = counts[k];
    const unsigned char* in = ins[k];
    for (const Column& c : cols) {
      if (n)
        std::memcpy(static_cast<unsigned char*>(c.data) + first * c.elem_bytes, in,
                    n * c.elem_bytes);
      in += n * c.elem_bytes;
    }
    first += n;
  }
}

void RowCopier::do_remove(std::span<const Column> cols, std::size_t n,
                          std::span<const std::uint32_t> gone) {
  for (const Column& c : cols) {
    auto* d = static_cast<unsigned char*>(c.data);
    const std::size_t e = c.elem_bytes;
    std::size_t to = 0, g = 0;
    for (std::size_t i = 0; i < n; ++i) {
      if (g < gone.size() && gone[g] == i) {
        ++g;
        continue;
      }
      if (to != i) // to < i: forward moves only
        std::memcpy(d + to * e, d + i * e, e);
      ++to;
    }
  }
}

std::size_t RowCopier::do_keep_flagged(std::span<const Column> cols, std::size_t n,
                                       const std::uint32_t* keep) {
  std::size_t kept = 0;
  for (std::size_t i = 0; i < n; ++i)
    kept += keep[i] != 0;
  for (const Column& c : cols) {
    auto* d = static_cast<unsigned char*>(c.data);
    const std::size_t e = c.elem_bytes;
    std::size_t to = 0;
    for (std::size_t i = 0; i < n; ++i)
      if (keep[i]) {
        if (to != i) // to < i: forward moves only
          std::memcpy(d + to * e, d + i * e, e);
        ++to;
      }
  }
  return kept;
}

unsigned char* RowCopier::do_message(std::size_t slot, std::size_t bytes) {
  if (messages_.size() <= slot)
    messages_.resize(slot + 1);
  auto& m = messages_[slot];
  if (m.size() < bytes)
    m.resize(bytes);
  return m.data();
}

void RowCopier::do_remap(RowList& list, Column new_of_old) {
  const auto* map = static_cast<const std::uint32_t*>(new_of_old.data);
  std::vector<std::uint32_t> moved(list.size());
  const auto& rows = rows_of(list);
  for (std::size_t k = 0; k < moved.size(); ++k)
    moved[k] = map[rows[k]];
  list.set(std::move(moved));
}

RowList RowCopier::do_remapped_range(Column new_of_old, std::size_t first, std::size_t n) {
  const auto* map = static_cast<const std::uint32_t*>(new_of_old.data);
  return RowList(std::vector<std::uint32_t>(map + first, map + first + n));
}

void RowCopier::do_rows_to_host(const RowList&) {
  throw Error("row copier: a list's rows are held by another copier");
}

void RowCopier::do_copy_rows(const RowList& list, std::uint32_t* out) {
  const auto& rows = rows_of(list);
  std::copy(rows.begin(), rows.end(), out);
}

RowList RowCopier::do_adopt(const std::uint32_t* rows, std::size_t n) {
  return RowList(std::vector<std::uint32_t>(rows, rows + n));
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

void RowCopier::gather(std::span<const Column> cols, std::span<const RowList> lists,
                       std::span<unsigned char* const> outs) {
  const AddTime t{seconds_};
  do_gather(cols, lists, outs);
}
void RowCopier::put(std::span<const Column> cols, std::size_t first,
                    std::span<const std::size_t> counts,
                    std::span<const unsigned char* const> ins) {
  const AddTime t{seconds_};
  do_put(cols, first, counts, ins);
}
void RowCopier::scatter(std::span<const Column> cols, const RowList& slots,
                        std::span<const std::size_t> counts,
                        std::span<const unsigned char* const> ins) {
  const AddTime t{seconds_};
  do_scatter(cols, slots, counts, ins);
}
void RowCopier::remove(std::span<const Column> cols, std::size_t n,
                       std::span<const std::uint32_t> gone) {
  const AddTime t{seconds_};
  do_remove(cols, n, gone);
}
std::size_t RowCopier::keep_flagged(std::span<const Column> cols, std::size_t n,
                                    const std::uint32_t* keep) {
  const AddTime t{seconds_};
  return n ? do_keep_flagged(cols, n, keep) : 0;
}

void RowCopier::remap(RowList& list, Column new_of_old) {
  if (new_of_old.elem_bytes != sizeof(std::uint32_t))
    throw Error("row copier: a remap needs a column of 32-bit indices");
  const AddTime t{seconds_};
  if (list.size())
    do_remap(list, new_of_old);
}
RowList RowCopier::remapped_range(Column new_of_old, std::size_t first, std::size_t n) {
  if (new_of_old.elem_bytes != sizeof(std::uint32_t))
    throw Error("row copier: a remap needs a column of 32-bit indices");
  const AddTime t{seconds_};
  return n ? do_remapped_range(new_of_old, first, n) : RowList();
}
const std::vector<std::uint32_t>& RowCopier::rows_of(const RowList& list) {
  if (!list.on_host) {
    do_rows_to_host(list);
    list.on_host = true;
  }
  return list.rows;
}
RowList RowCopier::adopt(const std::uint32_t* rows, std::size_t n) {
  return n ? do_adopt(rows, n) : RowList();
}
void RowCopier::copy_rows(const RowList& list, std::uint32_t* out) {
  if (list.size())
    do_copy_rows(list, out);
}

RowCopier& host_rows() {
  static RowCopier host;
  return host;
}

} // namespace kf::comm
