#include "comm/HaloExchange.hpp"

#include "core/Error.hpp"

#include <algorithm>
#include <cstring>
#include <string>

namespace kf::comm {

HaloExchange::HaloExchange(Transport& transport, std::vector<int> peers,
                           std::vector<std::vector<std::uint32_t>> send, RowCopier& rows)
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
  out_.resize(peers_.size());
  in_.resize(peers_.size());
}

std::size_t HaloExchange::sent() const {
  std::size_t n = 0;
  for (const auto& s : send_)
    n += s.size();
  return n;
}

void HaloExchange::start(std::span<const Column> columns, std::size_t first_ghost) {
  const std::size_t row = row_bytes(columns);
  std::vector<SendBuffer> sends(peers_.size());
  std::vector<RecvBuffer> recvs(peers_.size());
  last_bytes_ = 0;
  for (std::size_t k = 0; k < peers_.size(); ++k) {
    auto& out = out_[k];
    out.resize(send_[k].size() * row);
    rows_.gather(columns, send_[k], out.data());
    in_[k].resize(recv_count_[k] * row);
    sends[k] = {peers_[k], out.data(), out.size()};
    recvs[k] = {peers_[k], in_[k].data(), in_[k].size()};
    last_bytes_ += out.size();
  }
  pending_.assign(columns.begin(), columns.end());
  pending_first_ = first_ghost;
  transport_.start(sends, recvs);
}

void HaloExchange::finish() {
  transport_.finish();
  for (std::size_t k = 0; k < peers_.size(); ++k) {
    const std::size_t n = recv_count_[k];
    if (recv_slot_.empty())
      rows_.put(pending_, pending_first_ + recv_offset_[k], n, in_[k].data());
    else
      rows_.scatter(pending_, {recv_slot_.data() + recv_offset_[k], n}, in_[k].data());
  }
  pending_.clear();
}

void HaloExchange::remap(std::span<const std::uint32_t> new_of_old, std::size_t first_ghost) {
  if (first_ghost + recv_total_ > new_of_old.size())
    throw Error("halo exchange: a remap of " + std::to_string(new_of_old.size()) +
                " elements for " + std::to_string(first_ghost) + " owned and " +
                std::to_string(recv_total_) + " ghosts");
  for (auto& list : send_)
    for (std::uint32_t& i : list)
      i = new_of_old[i];
  std::vector<std::uint32_t> slots(recv_total_);
  for (std::size_t k = 0; k < recv_total_; ++k)
    slots[k] = recv_slot_.empty() ? new_of_old[first_ghost + k] : new_of_old[recv_slot_[k]];
  recv_slot_ = std::move(slots);
}

std::size_t migrate(Transport& transport, std::span<const int> peers,
                    std::span<const int> destination, std::span<MigrationColumn> columns,
                    RowCopier& rows) {
  const std::size_t n = destination.size();
  const int me = transport.rank();
  std::vector<std::vector<std::uint32_t>> leaving(peers.size());
  std::vector<std::uint32_t> staying;
  staying.reserve(n);
  for (std::size_t i = 0; i < n; ++i) {
    const int d = destination[i];
    if (d == me)
      staying.push_back(static_cast<std::uint32_t>(i));
    if (d == me || d < 0)
      continue;
    const auto it = std::find(peers.begin(), peers.end(), d);
    if (it == peers.end())
      throw Error("migration: particle " + std::to_string(i) + " goes to rank " +
                  std::to_string(d) + ", which is not a neighbour of rank " + std::to_string(me));
    leaving[it - peers.begin()].push_back(static_cast<std::uint32_t>(i));
  }
  std::vector<Column> cols(columns.size());
  for (std::size_t c = 0; c < columns.size(); ++c) // the current data (the size does not change)
    cols[c] = {columns[c].resize(n), columns[c].elem_bytes};
  const std::size_t row = row_bytes(cols);
  // The leavers, packed per peer.
  std::vector<std::uint64_t> counts(peers.size());
  std::vector<std::vector<unsigned char>> out(peers.size());
  for (std::size_t k = 0; k < peers.size(); ++k) {
    counts[k] = leaving[k].size();
    out[k].resize(leaving[k].size() * row);
    rows.gather(cols, leaving[k], out[k].data());
  }
  const auto arriving = transport.exchange_sizes(peers, counts);
  std::vector<std::vector<unsigned char>> in(peers.size());
  std::vector<SendBuffer> sends(peers.size());
  std::vector<RecvBuffer> recvs(peers.size());
  std::size_t arrivals = 0;
  for (std::size_t k = 0; k < peers.size(); ++k) {
    in[k].resize(arriving[k] * row);
    sends[k] = {peers[k], out[k].data(), out[k].size()};
    recvs[k] = {peers[k], in[k].data(), in[k].size()};
    arrivals += arriving[k];
  }
  transport.start(sends, recvs);
  // Meanwhile the particles that stay close up, in order.
  if (staying.size() != n)
    rows.compact(cols, staying);
  transport.finish();
  const std::size_t kept = staying.size(), total = kept + arrivals;
  for (std::size_t c = 0; c < columns.size(); ++c)
    cols[c].data = columns[c].resize(total);
  std::size_t at = kept;
  for (std::size_t k = 0; k < peers.size(); ++k) {
    rows.put(cols, at, arriving[k], in[k].data());
    at += arriving[k];
  }
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
