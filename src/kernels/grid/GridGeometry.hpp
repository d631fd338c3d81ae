#pragma once
// Uniform grid of cubic cells (edge = the largest interaction radius) and the neighbour loop every
// gather kernel uses. Particles are sorted by cell in Morton order; `rank` maps a cell's linear index
// to its position in that order, where `start/end` hold the cell's particle range.
#include "core/HostDevice.hpp"
#include "core/Math.hpp"
#include "core/Vec3.hpp"

#include <cstdint>

namespace kf {

template <typename T>
struct GridGeometry {
  Vec3<T> origin{};
  T cell = T(1);
  T inv_cell = T(1);
  int nx = 1, ny = 1, nz = 1;

  KF_HD KF_INLINE std::uint32_t cells() const {
    return static_cast<std::uint32_t>(nx) * static_cast<std::uint32_t>(ny) *
           static_cast<std::uint32_t>(nz);
  }
  KF_HD KF_INLINE static int clampi(int v, int lo, int hi) { return v < lo ? lo : (v > hi ? hi : v); }
  /// Cell coordinates of a point; points outside the grid fall into the nearest edge cell.
  KF_HD KF_INLINE void coords(const Vec3<T>& x, int& ix, int& iy, int& iz) const {
    ix = clampi(static_cast<int>(kfloor((x.x - origin.x) * inv_cell)), 0, nx - 1);
    iy = clampi(static_cast<int>(kfloor((x.y - origin.y) * inv_cell)), 0, ny - 1);
    iz = clampi(static_cast<int>(kfloor((x.z - origin.z) * inv_cell)), 0, nz - 1);
  }
  KF_HD KF_INLINE std::uint32_t linear(int ix, int iy, int iz) const {
    return (static_cast<std::uint32_t>(iz) * static_cast<std::uint32_t>(ny) +
            static_cast<std::uint32_t>(iy)) *
               static_cast<std::uint32_t>(nx) +
           static_cast<std::uint32_t>(ix);
  }
};

/// Read-only view of one particle set's cell tables, passed by value into kernels.
template <typename T>
struct CellView {
  GridGeometry<T> geo;
  const std::uint32_t* rank = nullptr;  // linear cell -> Morton rank
  const std::uint32_t* start = nullptr; // Morton rank -> first particle
  const std::uint32_t* end = nullptr;   // Morton rank -> one past last particle

  /// Calls f(j) for every particle j in the 27 cells around x (a superset of the particles within
  /// one cell edge of x); f filters by distance itself.
  template <typename F>
  KF_HD KF_INLINE void for_each_candidate(const Vec3<T>& x, F&& f) const {
    int cx, cy, cz;
    geo.coords(x, cx, cy, cz);
    const int z0 = cz > 0 ? cz - 1 : 0, z1 = cz < geo.nz - 1 ? cz + 1 : cz;
    const int y0 = cy > 0 ? cy - 1 : 0, y1 = cy < geo.ny - 1 ? cy + 1 : cy;
    const int x0 = cx > 0 ? cx - 1 : 0, x1 = cx < geo.nx - 1 ? cx + 1 : cx;
    for (int z = z0; z <= z1; ++z)
      for (int y = y0; y <= y1; ++y)
        for (int xx = x0; xx <= x1; ++xx) {
          const std::uint32_t c = rank[geo.linear(xx, y, z)];
          const std::uint32_t e = end[c];
          for (std::uint32_t j = start[c]; j < e; ++j) f(j);
        }
  }
};

} // namespace kf
