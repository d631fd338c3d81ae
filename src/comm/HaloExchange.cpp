#include "comm/HaloExchange.hpp"

#include "core/Error.hpp"

#include <algorithm>
#include <cstring>
#include <string>

namespace kf::comm {

HaloExchange::HaloExchange(Transport& transport, std::vector<int> peers,
                           std::vector<std::vector<std::uint32_t>> send)
    : transport_(transport), peers_(std::move(peers)), send_(std::move(send)) {
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
  row_bytes_ = 0;
  for (const Column& c : columns)
    row_bytes_ += c.elem_bytes;
  std::vector<SendBuffer> sends(peers_.size());
  std::vector<RecvBuffer> recvs(peers_.size());
  last_bytes_ = 0;
  for (std::size_t k = 0; k < peers_.size(); ++k) {
    // Column-major within a message: each column's values for the listed particles in a run,
    // so unpacking is one copy per column.
    auto& out = out_[k];
    out.resize(send_[k].size() * row_bytes_);
    unsigned char* o = out.data();
    for (const Column& c : columns) {
      const auto* src = static_cast<const unsigned char*>(c.data);
      for (std::uint32_t i : send_[k]) {
        std::memcpy(o, src + std::size_t(i) * c.elem_bytes, c.elem_bytes);
        o += c.elem_bytes;
      }
    }
    in_[k].resize(recv_count_[k] * row_bytes_);
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
    const unsigned char* in = in_[k].data();
    const std::size_t n = recv_count_[k];
    for (const Column& c : pending_) {
      auto* base = static_cast<unsigned char*>(c.data);
      if (recv_slot_.empty()) {
        if (n)
          std::memcpy(base + (pending_first_ + recv_offset_[k]) * c.elem_bytes, in,
                      n * c.elem_bytes);
      } else {
        const std::uint32_t* slot = recv_slot_.data() + recv_offset_[k];
        for (std::size_t j = 0; j < n; ++j)
          std::memcpy(base + std::size_t(slot[j]) * c.elem_bytes, in + j * c.elem_bytes,
                      c.elem_bytes);
      }
      in += n * c.elem_bytes;
    }
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
                    std::span<const int> destination, std::span<MigrationColumn> columns) {
  const std::size_t n = destination.size();
  const int me = transport.rank();
  std::vector<std::vector<std::uint32_t>> leaving(peers.size());
  for (std::size_t i = 0; i < n; ++i) {
    const int d = destination[i];
    if (d == me || d < 0)
      continue;
    const auto it = std::find(peers.begin(), peers.end(), d);
    if (it == peers.end())
      throw Error("migration: particle " + std::to_string(i) + " goes to rank " +
                  std::to_string(d) + ", which is not a neighbour of rank " + std::to_string(me));
    leaving[it - peers.begin()].push_back(static_cast<std::uint32_t>(i));
  }
  std::size_t row = 0;
  std::vector<unsigned char*> data(columns.size());
  for (std::size_t c = 0; c < columns.size(); ++c) {
    row += columns[c].elem_bytes;
    data[c] = columns[c].resize(n); // the current data (the size does not change)
  }
  // The leavers, packed column-major per peer.
  std::vector<std::uint64_t> counts(peers.size());
  std::vector<std::vector<unsigned char>> out(peers.size());
  for (std::size_t k = 0; k < peers.size(); ++k) {
    counts[k] = leaving[k].size();
    out[k].resize(leaving[k].size() * row);
    unsigned char* o = out[k].data();
    for (std::size_t c = 0; c < columns.size(); ++c) {
      const std::size_t e = columns[c].elem_bytes;
      for (std::uint32_t i : leaving[k]) {
        std::memcpy(o, data[c] + std::size_t(i) * e, e);
        o += e;
      }
    }
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
  // Meanwhile the particles that stay close up, in order (k <= i: forward moves only).
  std::size_t kept = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (destination[i] != me)
      continue;
    if (kept != i)
      for (std::size_t c = 0; c < columns.size(); ++c) {
        const std::size_t e = columns[c].elem_bytes;
        std::memcpy(data[c] + kept * e, data[c] + i * e, e);
      }
    ++kept;
  }
  transport.finish();
  const std::size_t total = kept + arrivals;
  for (std::size_t c = 0; c < columns.size(); ++c)
    data[c] = columns[c].resize(total);
  std::size_t at = kept;
  for (std::size_t k = 0; k < peers.size(); ++k) {
    const unsigned char* src = in[k].data();
    const std::size_t m = arriving[k];
    for (std::size_t c = 0; c < columns.size(); ++c) {
      const std::size_t e = columns[c].elem_bytes;
      if (m)
        std::memcpy(data[c] + at * e, src, m * e);
      src += m * e;
    }
    at += m;
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
