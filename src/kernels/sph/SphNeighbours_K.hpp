#pragma once
// Where an SPH particle's neighbours come from, for the evaluators: its fluid and boundary
// neighbours through one interface, either walked in the grids (SphCellWalk) or read from one
// list per particle holding both (SphList), built by SphChunkListBuilder. Both call the fluid
// callback for the fluid grid's candidates in cell order, then the boundary callback for the
// boundary grid's, so a list built this step gives the same sums bit for bit.
#include "kernels/grid/NeighbourList.hpp"
#include "kernels/grid/StagedRowAppender.hpp"
#include "kernels/sph/Sph.hpp"

#include <type_traits>

namespace kf {

/// The neighbour copy xm[i] = (x_i, m_i) the density pass and the cell list builder read.
template <typename T>
struct PackPositionMass {
  FluidView<T> f;
  KF_HD KF_INLINE void operator()(std::size_t i) const {
    const Vec3<T> x = f.x[i];
    f.xm[i] = {x.x, x.y, x.z, f.m[i]};
  }
};

/// Marks a list entry as a boundary particle's index (fluid counts stay below 2^31).
constexpr std::uint32_t kBoundaryEntry = 0x80000000u;

template <typename T>
struct SphCellWalk {
  static constexpr bool kListed = false; // most candidates are out of range (~85%)
  CellView<T> cells;
  BoundaryNeighbours<T> b;
  template <typename FF, typename FB>
  KF_HD KF_INLINE void for_each_neighbour(std::size_t, const Vec3<T>& x, FF&& fluid,
                                          FB&& boundary) const {
    cells.for_each_candidate(x, fluid);
    if (b.around(x))
      b.cells.for_each_candidate(x, boundary);
  }
};

template <typename T>
struct SphList {
  static constexpr bool kListed = true; // most entries are in range (all but the skin's shell)
  ListView<T> list;
  template <typename FF, typename FB>
  KF_HD KF_INLINE void for_each_neighbour(std::size_t i, const Vec3<T>&, FF&& fluid,
                                          FB&& boundary) const {
    auto one = [&](std::uint32_t j) {
      if (j & kBoundaryEntry)
        boundary(j & ~kBoundaryEntry);
      else
        fluid(j);
    };
    list.for_each_group(i, [&](const std::uint32_t(&e)[kListGroup], std::uint32_t m) {
      // A row lists its fluid neighbours before its boundary ones, so a full group whose last
      // entry is fluid is all fluid: its entries run without a test between them.
      visit_group(e, m, m == kListGroup && (e[kListGroup - 1] & kBoundaryEntry) == 0, fluid, one);
    });
  }
};

/// Row i: the fluid particles, then the boundary particles, within sqrt(radius2) of particle i,
/// in the grids' candidate order (the one-lane walk's), built by groups of lanes over
/// consecutive particles (exec::for_each_chunk, lane l taking particle first + l). The group's
/// particles whose cells share a row (y, z) walk that row's cells together: the union of their
/// candidate rows, each candidate loaded once for all lanes (a shared tile on the GPU). A lane
/// keeps its hits among 32 candidates as bits and appends them in order through a ring
/// (StagedRowAppender, in shared memory on the GPU). Cells are as wide as the radius, so a
/// particle's neighbours lie in its own (2 span + 1)^3 cells; the union visits the rows in the same
/// order, each a range holding the particle's own, so each row is the one-lane walk's entry for
/// entry. Why: the builder before, 16 lanes a particle, ran a ballot and a scattered store per
/// candidate (ncu: issue-bound at ~50 instructions a candidate); a warp per cell left most lanes
/// idle where the fluid thins. Requires the boundary grid of the same geometry as the fluid's, and
/// x sorted as `cells` describes.
template <typename T>
struct SphChunkListBuilder {
  const Vec4<T>* xm; // fluid (x, m): one 16-byte load a candidate
  CellView<T> cells;
  BoundaryNeighbours<T> b;
  T radius2;
  ListSink out;
  std::size_t n;

  KF_HD KF_INLINE static Vec3<T> at(const Vec4<T>& p) { return p.xyz(); }
  KF_HD KF_INLINE static Vec3<T> at(const Vec3<T>& p) { return p; }

  KF_HD void operator()(std::size_t first, exec::Lanes g) const {
#if defined(__CUDA_ARCH__)
    constexpr std::uint32_t kStride = 32; // lanes of a warp
    __shared__ std::uint32_t ring[exec::kChunkBlock * kStageSlots];
    std::uint32_t* slots = ring + (threadIdx.x / 32u) * (32u * kStageSlots) + (threadIdx.x % 32u);
    __shared__ alignas(16) T tiles[exec::kChunkBlock * 4]; // a warp's block: 32 x (x, y, z, -)
    T* tile = tiles + (threadIdx.x / 32u) * (32u * 4u);
#else
    constexpr std::uint32_t kStride = 1;
    std::uint32_t ring[kStageSlots];
    std::uint32_t* slots = ring;
#endif
    const std::size_t i = first + g.lane;
    const bool mine = i < n; // lanes past the end walk along, appending nothing
    const Vec3<T> xi = xm[mine ? i : first].xyz();
    int cx, cy, cz;
    cells.geo.coords(xi, cx, cy, cz);
    const bool near = mine && b.around(xi);
    StagedRowAppender<kStride> row(out, i, slots);
    // Appends the hits among 32 candidates from `base` (tagged), 16 at a time: the ring holds
    // 7 unwritten entries at most before a push.
    auto append = [&](std::uint32_t base, std::uint32_t hits) {
      row.push_bits(base, hits & 0xFFFFu);
      row.flush();
      row.push_bits(base + 16u, hits >> 16);
      row.flush();
    };
    // Appends, in order, the candidates pts[lo, hi) within the radius (on lanes that `take`),
    // tested 32 at a time (a block, unrolled). Past hi a block holds positions no lane is near.
    // On the GPU the warp first loads the block into its shared tile, a lane a candidate, one
    // block ahead: ncu put 74% of the tests' stalls on their loads when every lane read all 32
    // candidates from L1 or L2 just as it tested them.
    const T far = T(1e30); // its square overflows a float to infinity: never within the radius
    auto scan = [&](std::uint32_t lo, std::uint32_t hi, bool take, std::uint32_t tag,
                    const auto* pts) {
      auto fetch = [&](std::uint32_t j) { return j < hi ? at(pts[j]) : Vec3<T>{far, far, far}; };
#if defined(__CUDA_ARCH__)
      Vec3<T> next = fetch(lo + g.lane);
#endif
      for (std::uint32_t base = lo; base < hi; base += 32) {
#if defined(__CUDA_ARCH__)
        __syncwarp(); // every lane is done with the last block
        tile[4 * g.lane] = next.x;
        tile[4 * g.lane + 1] = next.y;
        tile[4 * g.lane + 2] = next.z;
        __syncwarp();
        next = fetch(base + 32 + g.lane);
        auto position = [&](std::uint32_t t) {
          if constexpr (std::is_same_v<T, float>) {
            const float4 p = reinterpret_cast<const float4*>(tile)[t];
            return Vec3<T>{p.x, p.y, p.z};
          } else {
            return Vec3<T>{tile[4 * t], tile[4 * t + 1], tile[4 * t + 2]};
          }
        };
#else
        auto position = [&](std::uint32_t t) { return fetch(base + t); };
#endif
        std::uint32_t hits = 0;
        KF_UNROLL
        for (std::uint32_t t = 0; t < 32; ++t)
          hits |= (norm2(xi - position(t)) < radius2 ? 1u : 0u) << t;
        append(base | tag, take ? hits : 0u);
      }
    };
    bool pending = mine;
    for (unsigned lead = g.first_set(pending); lead < g.size; lead = g.first_set(pending)) {
      // The lanes in the lead lane's row of cells, and the cells along x they span.
      const int ry = g.broadcast(cy, lead), rz = g.broadcast(cz, lead);
      const bool active = pending && cy == ry && cz == rz;
      const int x0 = g.min(active ? cx : cells.geo.nx), x1 = g.max(active ? cx : -1);
      cells.for_each_row_range(x0, x1, ry, rz, [&](std::uint32_t lo, std::uint32_t hi) {
        scan(lo, hi, active, 0u, xm);
      });
      if (g.any(active && near))
        b.cells.for_each_row_range(x0, x1, ry, rz, [&](std::uint32_t lo, std::uint32_t hi) {
          scan(lo, hi, active && near, kBoundaryEntry, b.x);
        });
      pending = pending && !active;
    }
    if (mine)
      row.finish();
  }
};

} // namespace kf
