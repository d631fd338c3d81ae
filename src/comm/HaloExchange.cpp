#include "comm/HaloExchange.hpp"

#include "core/Error.hpp"

#include <algorithm>
#include <cstring>
#include <string>

namespace kf::comm {

HaloExchange::HaloExchange(Transport& transport, std::vector<int> peers,
                           std::vector<std::vector<std::uint32_t>> send, RowCopier& rows)
    : HaloExchange(
          transport, std::move(peers),
          [&send] {
            std::vector<RowList> lists;
            for (auto& list : send)
              lists.emplace_back(std::move(list));
            return lists;
          }(),
          rows) {}

HaloExchange::HaloExchange(Transport& transport, std::vector<int> peers, std::vector<RowList> send,
                           RowCopier& rows)
    : transport_(transport), rows_(rows), peers_(std::move(peers)), send_(std::move(send)) {
  if (send_.size() != peers_.size())
    throw Error("halo exchange: " + std::to_string(send_.size()) + " send lists for " +
                std::to_string(peers_.size()) + " peers");
  // Counts of particles, not bytes: the columns are chosen per refresh.
  std::vector<std::uint64_t> counts(peers_.size());
  for (std::size_t k = 0; k < peers_.size(); ++k)
    counts[k] = send_[k].size();
  const auto got = transport_.exchange_sizes(peers_, counts);
  recv_count_.assign(got.begin(), got.end());
  recv_offset_.resize(peers_.size());
  for (std::size_t k = 0; k < peers_.size(); ++k) {
    recv_offset_[k] = recv_total_;
    recv_total_ += recv_count_[k];
  }
  in_.resize(peers_.size());
}

std::size_t HaloExchange::sent() const {
  std::size_t n = 0;
  for (const auto& s : send_)
    n += s.size();
  return n;
}

std::vector<std::uint32_t> HaloExchange::sent_rows() const {
  std::vector<std::uint32_t> rows;
  rows.reserve(sent());
  for (const auto& s : send_) {
    const auto& r = rows_.rows_of(s);
    rows.insert(rows.end(), r.begin(), r.end());
  }
  return rows;
}

void HaloExchange::copy_sent_rows(std::uint32_t* out) const {
  for (const auto& s : send_) {
    rows_.copy_rows(s, out);
    out += s.size();
  }
}

void HaloExchange::copy_ghost_rows(std::uint32_t* out, std::size_t first_ghost) const {
  if (recv_total_ == 0)
    return;
  if (recv_slot_.size() != 0) {
    rows_.copy_rows(recv_slot_, out);
    return;
  }
  std::vector<std::uint32_t> rows(recv_total_);
  for (std::size_t k = 0; k < recv_total_; ++k)
    rows[k] = static_cast<std::uint32_t>(first_ghost + k);
  rows_.copy_rows(RowList(std::move(rows)), out);
}

void HaloExchange::start(std::span<const Column> columns, std::size_t first_ghost) {
  const std::size_t row = row_bytes(columns);
  std::vector<SendBuffer> sends(peers_.size());
  std::vector<RecvBuffer> recvs(peers_.size());
  std::vector<unsigned char*> outs(peers_.size());
  last_bytes_ = 0;
  for (std::size_t k = 0; k < peers_.size(); ++k) {
    const std::size_t out_bytes = send_[k].size() * row, in_bytes = recv_count_[k] * row;
    outs[k] = rows_.message(2 * k, out_bytes);
    in_[k] = rows_.message(2 * k + 1, in_bytes);
    sends[k] = {peers_[k], outs[k], out_bytes};
    recvs[k] = {peers_[k], in_[k], in_bytes};
    last_bytes_ += out_bytes;
  }
  rows_.gather(columns, send_, outs); // every peer's message at once
  pending_.assign(columns.begin(), columns.end());
  pending_first_ = first_ghost;
  transport_.start(sends, recvs);
  in_flight_ = true;
}

void HaloExchange::finish() {
  in_flight_ = false;
  transport_.finish();
  const std::vector<const unsigned char*> ins(in_.begin(), in_.end());
  if (recv_slot_.size() == 0)
    rows_.put(pending_, pending_first_, recv_count_, ins);
  else
    rows_.scatter(pending_, recv_slot_, recv_count_, ins);
  pending_.clear();
}

void HaloExchange::remap(Column new_of_old, std::size_t first_ghost) {
  for (auto& list : send_)
    rows_.remap(list, new_of_old);
  if (recv_slot_.size() == 0) // contiguous from first_ghost until now
    recv_slot_ = rows_.remapped_range(new_of_old, first_ghost, recv_total_);
  else
    rows_.remap(recv_slot_, new_of_old);
}

void HaloExchange::add_to_owners(std::span<std::uint64_t> values, std::size_t width,
                                 std::size_t first_ghost) const {
  const std::size_t rows_held = width ? values.size() / width : 0;
  if (width == 0 || values.size() % width != 0 || rows_held < first_ghost + recv_total_)
    throw Error("halo exchange: sums of " + std::to_string(values.size()) + " values, " +
                std::to_string(width) + " a row, for " + std::to_string(first_ghost) +
                " owned rows and " + std::to_string(recv_total_) + " ghosts");
  std::vector<std::vector<std::uint64_t>> out(peers_.size()), in(peers_.size());
  std::vector<SendBuffer> sends(peers_.size());
  std::vector<RecvBuffer> recvs(peers_.size());
  const std::vector<std::uint32_t>* slots =
      recv_slot_.size() ? &rows_.rows_of(recv_slot_) : nullptr;
  for (std::size_t k = 0; k < peers_.size(); ++k) {
    out[k].resize(recv_count_[k] * width);
    for (std::size_t i = 0; i < recv_count_[k]; ++i) {
      const std::size_t g = recv_offset_[k] + i;
      const std::size_t row = slots ? (*slots)[g] : first_ghost + g;
      std::copy_n(values.begin() + row * width, width, out[k].begin() + i * width);
    }
    in[k].resize(send_[k].size() * width);
    sends[k] = {peers_[k], out[k].data(), out[k].size() * sizeof(std::uint64_t)};
    recvs[k] = {peers_[k], in[k].data(), in[k].size() * sizeof(std::uint64_t)};
  }
  transport_.exchange_host(sends, recvs);
  for (std::size_t k = 0; k < peers_.size(); ++k) {
    const auto& sent = rows_.rows_of(send_[k]);
    for (std::size_t i = 0; i < sent.size(); ++i)
      for (std::size_t c = 0; c < width; ++c)
        values[sent[i] * width + c] += in[k][i * width + c];
  }
}

Departures Departures::of(std::span<const int> destination, int me) {
  Departures d;
  d.n = destination.size();
  for (std::size_t i = 0; i < d.n; ++i)
    if (destination[i] != me) {
      d.index.push_back(static_cast<std::uint32_t>(i));
      d.to.push_back(destination[i]);
    }
  return d;
}

std::size_t migrate(Transport& transport, std::span<const int> peers,
                    std::span<const int> destination, std::span<MigrationColumn> columns,
                    RowCopier& rows) {
  return migrate(transport, peers, Departures::of(destination, transport.rank()), columns, rows);
}

std::size_t migrate(Transport& transport, std::span<const int> peers, const Departures& leaving,
                    std::span<MigrationColumn> columns, RowCopier& rows) {
  const std::size_t n = leaving.n;
  const int me = transport.rank();
  if (leaving.to.size() != leaving.index.size())
    throw Error("migration: " + std::to_string(leaving.index.size()) + " leavers with " +
                std::to_string(leaving.to.size()) + " destinations");
  if (leaving.in_place && !leaving.keep && n > 0)
    throw Error("migration: rows left in place need the flags of those that stay");
  std::vector<std::vector<std::uint32_t>> out_rows(peers.size());
  for (std::size_t k = 0; k < leaving.index.size(); ++k) {
    const std::uint32_t i = leaving.index[k];
    const int d = leaving.to[k];
    if (i >= n || (k > 0 && i <= leaving.index[k - 1]) || d == me)
      throw Error("migration: leaver " + std::to_string(k) + " (particle " + std::to_string(i) +
                  " of " + std::to_string(n) + ", to rank " + std::to_string(d) +
                  ") is out of order or stays");
    if (d < 0)
      continue;
    const auto it = std::find(peers.begin(), peers.end(), d);
    if (it == peers.end())
      throw Error("migration: particle " + std::to_string(i) + " goes to rank " +
                  std::to_string(d) + ", which is not a neighbour of rank " + std::to_string(me));
    out_rows[it - peers.begin()].push_back(i);
  }
  std::vector<Column> cols(columns.size());
  for (std::size_t c = 0; c < columns.size(); ++c) // the current data (the size does not change)
    cols[c] = {columns[c].resize(n), columns[c].elem_bytes};
  const std::size_t row = row_bytes(cols);
  // The leavers, packed per peer (all peers' messages at once).
  std::vector<std::uint64_t> counts(peers.size());
  std::vector<RowList> lists(peers.size());
  std::vector<unsigned char*> out(peers.size()), in(peers.size());
  for (std::size_t k = 0; k < peers.size(); ++k) {
    counts[k] = out_rows[k].size();
    out[k] = rows.message(2 * k, out_rows[k].size() * row);
    lists[k].set(std::move(out_rows[k]));
  }
  rows.gather(cols, lists, out);
  const auto arriving = transport.exchange_sizes(peers, counts);
  std::vector<SendBuffer> sends(peers.size());
  std::vector<RecvBuffer> recvs(peers.size());
  std::size_t arrivals = 0;
  for (std::size_t k = 0; k < peers.size(); ++k) {
    in[k] = rows.message(2 * k + 1, arriving[k] * row);
    sends[k] = {peers[k], out[k], lists[k].size() * row};
    recvs[k] = {peers[k], in[k], arriving[k] * row};
    arrivals += arriving[k];
  }
  transport.start(sends, recvs);
  // Meanwhile the particles that stay close up, in order.
  std::size_t kept = n - leaving.index.size();
  if (leaving.in_place)
    kept = n;
  else if (leaving.keep)
    kept = rows.keep_flagged(cols, n, leaving.keep);
  else if (!leaving.index.empty())
    rows.remove(cols, n, leaving.index);
  transport.finish();
  const std::size_t total = kept + arrivals;
  for (std::size_t c = 0; c < columns.size(); ++c)
    cols[c].data = columns[c].resize(total);
  const std::vector<std::size_t> arrived(arriving.begin(), arriving.end());
  const std::vector<const unsigned char*> ins(in.begin(), in.end());
  rows.put(cols, kept, arrived, ins);
  return total;
}

std::size_t migrate(Transport& transport, std::span<const int> peers,
                    std::span<const int> destination, std::span<const ByteColumn> columns) {
  std::vector<MigrationColumn> cols;
  for (const ByteColumn& c : columns) {
    if (c.bytes->size() != destination.size() * c.elem_bytes)
      throw Error("migration: a column holds " + std::to_string(c.bytes->size()) +
                  " bytes, expected " + std::to_string(destination.size()) + " x " +
                  std::to_string(c.elem_bytes));
    auto* v = c.bytes;
    const std::size_t e = c.elem_bytes;
    cols.push_back({e, [v, e](std::size_t n) {
                      v->resize(n * e);
                      return v->data();
                    }});
  }
  return migrate(transport, peers, destination, cols);
}

} // namespace kf::comm
