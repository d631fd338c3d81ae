#pragma once
// Signed-volume terms of the knit (paper §3: "volume-preserving" between the layers). Springs
// only see lengths, so a front layer pushed through the middle one (a mirror image) costs them
// nothing, and a crushed fold or an edge squashed on the floor can turn the fabric inside out.
// Each cell is a tetrahedron: a front or back point (the apex) over a corner triangle of the
// middle layer; its energy 1/2 k (V - V0)^2 grows as the apex crosses the middle layer, so the
// layers keep their order. Stored per point like the springs (gather, no atomics).
#include "core/Vec3.hpp"
#include "kernels/exec/Algorithms.hpp"
#include "kernels/exec/HostReadable.hpp"
#include "kernels/knit/RowLayout.hpp"

#include <array>
#include <cstdint>
#include <vector>

namespace kf {

/// One tetrahedron: point[0] the apex (layer 0 or 2), point[1] the middle-layer node under it,
/// point[2], point[3] two of that node's neighbours along u and v (host side, built once).
struct VolumeCell {
  std::array<std::uint32_t, 4> point{};
  double rest_volume = 0; // signed V0 [m^3]
  double k = 0;           // [N/m^5]
};

/// Signed volume V = (a - o) x (b - o) . (p - o) / 6 of (p, o, a, b) and its gradient with
/// respect to point r of the four.
template <typename T>
KF_HD KF_INLINE T tet_volume(const Vec3<T>& p, const Vec3<T>& o, const Vec3<T>& a,
                             const Vec3<T>& b) {
  return dot(cross(a - o, b - o), p - o) * (T(1) / T(6));
}

template <typename T>
KF_HD KF_INLINE Vec3<T> tet_volume_gradient(const Vec3<T>& p, const Vec3<T>& o, const Vec3<T>& a,
                                            const Vec3<T>& b, int r) {
  const T s = T(1) / T(6);
  const Vec3<T> gp = cross(a - o, b - o) * s, ga = cross(b - o, p - o) * s,
                gb = cross(p - o, a - o) * s;
  switch (r) {
  case 0:
    return gp;
  case 2:
    return ga;
  case 3:
    return gb;
  default:
    return -(gp + ga + gb);
  }
}

template <typename T>
struct VolumeView {
  const std::uint32_t* count = nullptr; // cells point i belongs to
  const std::uint32_t* cell = nullptr;  // its e-th at cell[rows.at(e, i)] (RowLayout)
  const std::uint32_t* point = nullptr; // 4 per cell
  const T* rest = nullptr;
  const T* k = nullptr;
  RowLayout rows;

  KF_HD KF_INLINE bool empty() const { return count == nullptr; }
};

template <typename T>
class VolumeTopology {
public:
  /// The whole mesh's cells on N ranks, on the host: each cell's corners (mesh indices) and
  /// constants, by mesh cell index.
  struct Cells {
    exec::HostReadable<std::uint32_t> point;
    exec::HostReadable<T> rest, k;
    std::size_t cells = 0;
  };
  /// A rank's points' rows on N ranks (as SpringTopology::HostRows): each point's cells, mesh cell
  /// indices in the mesh's order, row k the k-th local point's, row-major; they migrate with
  /// their points.
  struct HostRows {
    exec::HostReadable<std::uint32_t> count, cell;
    std::uint32_t width = 0;
    std::size_t points() const { return count.size(); }
    RowLayout rows() const { return {1, width}; }
    void resize(std::size_t n) {
      count.resize(n);
      cell.resize(n * width);
    }
  };
  /// The cells' corners and constants for kernels of backend b.
  static Cells mesh_cells(exec::Backend b, const std::vector<VolumeCell>& cells,
                          std::size_t n_points);
  /// The rows of points ids[0..] (row k: point ids[k]'s cells in the list's order) from a list
  /// over n_points points holding every cell of those points, index[c] cell c's mesh index
  /// (others are passed over); at least `width` wide.
  static HostRows host_rows(exec::Backend b, const std::vector<VolumeCell>& cells,
                            const std::vector<std::uint32_t>& index, std::size_t n_points,
                            const std::vector<std::uint64_t>& ids, std::uint32_t width = 0);

  explicit VolumeTopology(exec::Backend b);
  void build(const std::vector<VolumeCell>& cells, std::size_t n_points);
  /// On N ranks, as SpringTopology::localize: the first `owned` local points take their rows
  /// (in the mesh's order), the ghosts have no rows; the cells those rows name are gathered
  /// from the mesh's table into a compact one (the rows then index it), their corners mapped
  /// to local indices.
  void localize(const exec::Exec& ex, const Cells& cells, const HostRows& rows,
                const std::uint32_t* local_of_id, std::size_t owned);
  /// The points with rows (all of them; on N ranks the owned ones).
  std::size_t points() const { return count_.size(); }
  VolumeView<T> view() const;
  std::size_t cells() const { return cells_; }
  std::size_t bytes() const;

private:
  exec::DeviceBuffer<std::uint32_t> count_, cell_, point_;
  exec::DeviceBuffer<T> rest_, k_;
  // On N ranks, each mesh cell's compact slot (the used cells' corners and constants are the
  // rank's only); empty on one rank.
  exec::DeviceBuffer<std::uint32_t> slot_;
  std::size_t cells_ = 0;
  std::uint32_t width_ = 0; // the most cells of one point
  /// Where the rows sit: the backend's layout for these points and width.
  RowLayout rows() const { return RowLayout::for_backend(count_.backend(), count_.size(), width_); }
};

} // namespace kf
