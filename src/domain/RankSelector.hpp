#pragma once
// A rebuild's choices on N ranks, made on the particles' backend (DESIGN §6; the kernels in
// kernels/grid/RankSelection): which particles leave this rank (and where to) and which go to
// each neighbour as ghosts. The blocks' owners live in the backend's memory, uploaded at each
// partition; only the indices of the particles that move or are sent come to the host.
#include "comm/HaloExchange.hpp"
#include "domain/Decomposition.hpp"
#include "domain/GhostSelection.hpp"
#include "kernels/exec/DeviceBuffer.hpp"
#include "kernels/grid/RankSelection.hpp"

#include <array>
#include <cstdint>
#include <vector>

namespace kf {

template <typename T>
class RankSelector {
public:
  explicit RankSelector(exec::Backend backend);

  /// After every partition: the blocks' owners as `rank` sees them.
  void set(const Decomposition& d, int rank);

  struct Departures {
    comm::Departures leaving;
    std::uint64_t removed = 0; // of them, those past an open side (to = -1)
    double removed_mass = 0;
  };
  /// Of the first n particles (positions x, masses m): those whose block another rank owns and
  /// those past [lo, hi] on a side without a wall (walls: low x, high x, low y, ...). Where
  /// `owned` is given (1 owned, 0 a ghost held, on the backend) the ghosts are dropped too. The
  /// departures carry the flags of the rows that stay (Departures::keep, valid until the next
  /// call), the dropped ghosts' indices staying on the device.
  Departures departures(const exec::DeviceBuffer<Vec3<T>>& x, const exec::DeviceBuffer<T>& m,
                        std::size_t n, const Vec3<T>& lo, const Vec3<T>& hi,
                        const std::array<bool, 6>& walls, const std::uint32_t* owned = nullptr);
  /// The points per block of the partition set last, of the first n positions (where `only` is
  /// given, on the backend: the rows with only[i] != 0), counted on the backend: a block a count
  /// comes to the host, not the positions.
  std::vector<std::uint32_t> block_counts(const exec::DeviceBuffer<Vec3<T>>& x, std::size_t n,
                                          const std::uint32_t* only = nullptr);
  /// For the first n positions (owned by this rank): the local indices each neighbouring rank
  /// needs as ghosts, those within `width` of its blocks (select_ghosts' lists, ascending), held
  /// by `rows` (a device copier keeps them on the device: P9, their trip through the host at
  /// every rebuild; `rows.rows_of` brings one to the host).
  struct GhostRows {
    std::vector<int> peers;
    std::vector<comm::RowList> send;
  };
  /// alive (where given, on the backend): only rows with alive[i] != 0 are sent. wider: the
  /// points in its flagged cells go as far as its width (the peers are then those within it).
  GhostRows ghost_rows(const exec::DeviceBuffer<Vec3<T>>& x, std::size_t n, double width,
                       comm::RowCopier& rows, const std::uint32_t* alive = nullptr,
                       const WiderCells<T>& wider = {});

private:
  /// The peers within `width` (or wider's), and for each in turn `each(slot, rows, count)` with
  /// its rows (ascending, in the backend's memory, valid until the next call).
  template <typename Each>
  std::vector<int> choose_ghosts(const exec::DeviceBuffer<Vec3<T>>& x, std::size_t n, double width,
                                 const std::uint32_t* alive, const WiderCells<T>& wider, Each each);
  /// The first n elements of idx, on the host.
  std::vector<std::uint32_t> indices(std::size_t n) const;

  exec::Backend backend_;
  const Decomposition* decomposition_ = nullptr;
  int rank_ = 0;
  BlockGridView grid_;
  exec::DeviceBuffer<int> owner_, slot_, dest_, picked_dest_;
  exec::DeviceBuffer<std::uint32_t> flags_, offsets_, idx_, stay_, counts_;
  exec::DeviceBuffer<std::uint64_t> mask_;
  exec::DeviceBuffer<T> picked_m_;
  // The neighbours within a width, found over the blocks once a partition and width.
  std::vector<std::pair<double, std::vector<int>>> peers_;
};

} // namespace kf
