#pragma once
// Ghost refreshes between rebuilds (the molecular-dynamics pattern, DESIGN §6): the send lists are
// fixed when the ghost set is chosen; each refresh packs the listed particles' values of some
// columns, moves them through a Transport and writes what the peers send into the ghost slots,
// which follow the owned particles in the same arrays. Knows no physics: columns are bytes.
// The columns are read and written through a RowCopier (host memory by default; a device
// backend packs on the device and stages through the host). The messages are host memory.
#include "comm/RowCopier.hpp"
#include "comm/Transport.hpp"

#include <cstddef>
#include <cstdint>
#include <functional>
#include <span>
#include <vector>

namespace kf::comm {

class HaloExchange {
public:
  /// `peers` (distinct, and symmetric over the job: A lists B iff B lists A) and, for each, the
  /// local indices whose values it receives. Collective over the peers: learns how many ghosts
  /// each sends back (Transport::exchange_sizes). `rows` reads and writes the columns (it must
  /// outlive the exchange).
  HaloExchange(Transport& transport, std::vector<int> peers,
               std::vector<std::vector<std::uint32_t>> send, RowCopier& rows = host_rows());
  /// The same with lists the copier holds (RowCopier::adopt: chosen on a device, kept there).
  HaloExchange(Transport& transport, std::vector<int> peers, std::vector<RowList> send,
               RowCopier& rows);

  const std::vector<int>& peers() const { return peers_; }
  /// Ghosts received in all, and where peer k's start among them (peers in the given order).
  std::size_t received() const { return recv_total_; }
  std::size_t received_from(std::size_t k) const { return recv_count_[k]; }
  std::size_t offset_of(std::size_t k) const { return recv_offset_[k]; }
  std::size_t sent() const;
  /// The local indices sent to any peer, peer after peer (a row sent to two peers is listed
  /// twice): the border of this rank's region, what a pass must have computed before start().
  std::vector<std::uint32_t> sent_rows() const;
  /// The same written at `out` (sent() rows, memory of the copier's kind: no host round trip).
  void copy_sent_rows(std::uint32_t* out) const;
  /// Where the ghosts are (received() rows, ascending by peer and position in its message),
  /// written at `out` as copy_sent_rows writes: first_ghost + k until a remap, then their slots.
  void copy_ghost_rows(std::uint32_t* out, std::size_t first_ghost) const;
  /// Whether an exchange was started and not finished.
  bool pending() const { return in_flight_; }

  /// Packs the columns' values of the listed particles and posts the exchange; returns at once.
  /// Every rank must pass the same columns (count and element sizes) in the same order.
  void start(std::span<const Column> columns, std::size_t first_ghost);
  /// Waits, then writes peer k's values at first_ghost + offset_of(k) of each column.
  void finish();
  /// start + finish.
  void exchange(std::span<const Column> columns, std::size_t first_ghost) {
    start(columns, first_ghost);
    finish();
  }
  /// The reverse of an exchange, summing: each ghost's `width` values (host memory, rows of
  /// `values` from first_ghost on, as exchange() wrote them) go back to the peer that sent the
  /// ghost, which adds them to the row it sent (a row sent to several peers gets each one's).
  /// Wrapping integer sums: exact, in any order. Over MPI, host buffers (Transport::
  /// exchange_host); the ghosts' rows are left as they were. Collective over the peers.
  void add_to_owners(std::span<std::uint64_t> values, std::size_t width,
                     std::size_t first_ghost) const;
  /// Bytes sent by the last exchange (all peers).
  std::size_t last_bytes() const { return last_bytes_; }

  /// After the arrays were reordered (new_of_old: a column of uint32, element i where element i
  /// went, over owned and ghosts, in the copier's memory): the send lists follow their
  /// particles, and the ghosts, received at first_ghost + k, are scattered to where they went
  /// from then on. Reads only the listed elements, through the copier (a device copier maps its
  /// copies of the lists on the device: nothing crosses the bus).
  void remap(Column new_of_old, std::size_t first_ghost);

private:
  Transport& transport_;
  RowCopier& rows_;
  std::vector<int> peers_;
  std::vector<RowList> send_;
  std::vector<std::size_t> recv_count_, recv_offset_;
  std::size_t recv_total_ = 0;
  RowList recv_slot_; // empty: contiguous from first_ghost
  bool in_flight_ = false;
  std::vector<unsigned char*> in_; // the copier's messages, between start and finish
  std::vector<Column> pending_;
  std::size_t pending_first_ = 0, last_bytes_ = 0;
};

/// A column of the particles' state that migration can resize in place: `resize(n)` makes it
/// n elements, keeping the first min(old, n), and returns its data.
struct MigrationColumn {
  std::size_t elem_bytes = 0;
  std::function<unsigned char*(std::size_t)> resize;
};

/// The particles that leave a rank's n at a migration: `index` ascending, `to[k]` the new rank
/// of particle index[k] (-1: it is dropped, e.g. it left the domain); the others stay.
struct Departures {
  std::size_t n = 0;
  std::vector<std::uint32_t> index;
  std::vector<int> to;
  /// When given, the rows that stay (one flag a row, in the RowCopier's memory): the leavers are
  /// among the rows it leaves out, and so may be rows dropped without a message of their own (the
  /// ghosts a rank held), whose indices then need not come to the host.
  const std::uint32_t* keep = nullptr;
  /// With `keep`: nothing closes up; every row keeps its place and the arrivals follow row n-1.
  /// The caller drops the rows `keep` leaves out later (the sort after a rebuild, which moves
  /// every row anyway: one pass over the columns fewer).
  bool in_place = false;
  /// From every particle's destination (this rank: it stays).
  static Departures of(std::span<const int> destination, int me);
};

/// Moves particles to the ranks that now own them (DESIGN §6: at a rebuild, with every field).
/// Only the leavers are packed; the particles that stay close up in place (keeping their order)
/// while the messages are in flight, and the arrivals follow them, by sending rank, in the
/// sender's order (Departures::in_place: nothing closes up, the arrivals follow all n rows).
/// `peers` as for HaloExchange (every rank a particle may go to or come from). `rows` reads and
/// writes the columns' data. Returns the new count (of rows, with in_place).
std::size_t migrate(Transport& transport, std::span<const int> peers, const Departures& leaving,
                    std::span<MigrationColumn> columns, RowCopier& rows = host_rows());
/// The same from every particle's destination (this rank: it stays; -1: it is dropped).
std::size_t migrate(Transport& transport, std::span<const int> peers,
                    std::span<const int> destination, std::span<MigrationColumn> columns,
                    RowCopier& rows = host_rows());

/// The same over byte vectors (tests, host staging).
struct ByteColumn {
  std::vector<unsigned char>* bytes = nullptr;
  std::size_t elem_bytes = 0;
};
std::size_t migrate(Transport& transport, std::span<const int> peers,
                    std::span<const int> destination, std::span<const ByteColumn> columns);

} // namespace kf::comm
