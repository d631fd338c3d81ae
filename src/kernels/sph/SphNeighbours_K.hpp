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
/// candidate rows, each candidate loaded once for all lanes (on the GPU, those within reach of
/// the lanes' box, through a shared ring). A lane
/// keeps its hits among 32 candidates as bits and appends them in order through a ring
/// (StagedRowAppender, in shared memory on the GPU). Cells are as wide as the radius, so a
/// particle's neighbours lie in its own (2 span + 1)^3 cells; the union visits the rows in the same
/// order, each a range holding the particle's own, so each row is the one-lane walk's entry for
/// entry. Why: the builder before, 16 lanes a particle, ran a ballot and a scattered store per
/// candidate (ncu: issue-bound at ~50 instructions a candidate); a warp per cell left most lanes
/// idle where the fluid thins. Requires the boundary grid of the same geometry as the fluid's, and
/// x sorted as `cells` describes.
/// Warp false: on the GPU too a thread a particle, each walking its own rows (the same rows, the
/// CPU's code). A warp's 32 particles scattered over 32 rows of cells walk them one after the
/// other: the pour's last few thousand particles, spread over the knit, took 823 us a build
/// with 40 blocks (ncu; 65 us for its first 64k). SphLists picks by the particle count.
template <typename T, bool Warp = true>
struct SphChunkListBuilder {
  const Vec4<T>* xm; // fluid (x, m): one 16-byte load a candidate
  CellView<T> cells;
  BoundaryNeighbours<T> b;
  T radius2;
  ListSink out;
  std::size_t n;

  KF_HD void operator()(std::size_t first, exec::Lanes g) const {
    const std::size_t i = first + g.lane;
    const bool mine = i < n; // lanes past the end walk along, appending nothing
    const Vec3<T> xi = xm[mine ? i : first].xyz();
    int cx, cy, cz;
    cells.geo.coords(xi, cx, cy, cz);
    const bool near = mine && b.around(xi);
    // Appends this lane's hits among 32 candidates, entry(k) for candidate k, 16 at a time: the
    // ring holds 7 unwritten entries at most before a push.
    auto append_to = [](auto& row, std::uint32_t hits, auto&& entry) {
      row.push_each(hits & 0xFFFFu, entry);
      row.flush();
      row.push_each(hits >> 16, [&](unsigned k) { return entry(16u + k); });
      row.flush();
    };
#if defined(__CUDA_ARCH__)
    if constexpr (Warp) {
      __shared__ std::uint32_t ring[exec::kChunkBlock * kStageSlots];
      std::uint32_t* slots = ring + (threadIdx.x / 32u) * (32u * kStageSlots) + (threadIdx.x % 32u);
      // A warp's ring of 64 kept candidates, (x, y, z, -) each, and their list entries.
      __shared__ alignas(16) T tiles[exec::kChunkBlock * 2 * 4];
      __shared__ std::uint32_t tile_entries[exec::kChunkBlock * 2];
      T* const tiles_of_warp = tiles + (threadIdx.x / 32u) * (64u * 4u);
      std::uint32_t* const entries_of_warp = tile_entries + (threadIdx.x / 32u) * 64u;
      StagedRowAppender<32> row(out, i, slots);
      auto append = [&](std::uint32_t hits, auto&& entry) { append_to(row, hits, entry); };
      const T far = T(1e30); // its square overflows a float to infinity: never within the radius
      // The warp streams the candidates of a row group's rows through a shared ring, keeping
      // only those within the radius of the box of the taking lanes' points (no lane can hit the
      // others); each lane tests whole tiles of 32 kept candidates, unrolled. Kept candidates
      // keep their order, so rows are the one-lane walk's. Why: a warp's union of rows holds
      // ~1,700 candidates a particle, 62% of them within the radius of its lanes' box. Measured
      // (H100, the column's whole run): 4% off the build (2.46 against 2.57 ms), ncu 6% fewer
      // instructions; the pushes and the walk, not the tests, hold most of them.
      // Kept candidates: those from `tested` on are in the ring, up to `held` (the same on every
      // lane; `tested` a multiple of 32 but at a row group's end, when both restart at 0).
      std::uint32_t held = 0, tested = 0;
      Vec3<T> lo{far, far, far}, hi{-far, -far, -far};
      // Past the margin, rounding cannot make a candidate outside the box's reach hit a lane.
      const T reach2 = radius2 * T(1.0001);
      auto position = [&](const T* tile, std::uint32_t t) {
        if constexpr (std::is_same_v<T, float>) {
          const float4 p = reinterpret_cast<const float4*>(tile)[t];
          return Vec3<T>{p.x, p.y, p.z};
        } else {
          return Vec3<T>{tile[4 * t], tile[4 * t + 1], tile[4 * t + 2]};
        }
      };
      // Tests the 32 kept candidates from `tested` on, of which the first `count` are real, and
      // appends this lane's hits in order.
      auto test_tile = [&](std::uint32_t count, bool take) {
        __syncwarp(); // every lane's kept candidate is in the ring
        const T* tile = tiles_of_warp + 4u * (tested % 64u);
        const std::uint32_t* entries = entries_of_warp + tested % 64u;
        std::uint32_t hits = 0;
        KF_UNROLL
        for (std::uint32_t t = 0; t < 32; ++t)
          hits |= (norm2(xi - position(tile, t)) < radius2 ? 1u : 0u) << t;
        if (count < 32)
          hits &= (1u << count) - 1u;
        append(take ? hits : 0u, [&](unsigned k) { return entries[k]; });
        tested += 32;
        __syncwarp(); // every lane is done with these 32 before the ring reuses their slots
      };
      // Streams the candidates pts[lo, hi) (entries tagged), 32 a step, a lane a candidate, each
      // loaded one step ahead.
      auto scan = [&](std::uint32_t from, std::uint32_t to, bool take, std::uint32_t tag,
                      const auto* pts) {
        auto fetch = [&](std::uint32_t j) {
          return j < to ? position_of(pts[j]) : Vec3<T>{far, far, far};
        };
        Vec3<T> next = fetch(from + g.lane);
        for (std::uint32_t base = from; base < to; base += 32) {
          const Vec3<T> p = next;
          next = fetch(base + 32 + g.lane);
          // The distance from p to the box along each axis (0 inside its extent).
          const T dx = kmax(kmax(lo.x - p.x, p.x - hi.x), T(0)),
                  dy = kmax(kmax(lo.y - p.y, p.y - hi.y), T(0)),
                  dz = kmax(kmax(lo.z - p.z, p.z - hi.z), T(0));
          const bool keep = dx * dx + dy * dy + dz * dz < reach2; // far is never kept
          const std::uint32_t kept = g.ballot(keep);
          if (keep) { // held - tested < 32 before, so the ring's 64 slots hold them all
            const std::uint32_t t = (held + popcount(kept & ((1u << g.lane) - 1u))) % 64u;
            tiles_of_warp[4 * t] = p.x;
            tiles_of_warp[4 * t + 1] = p.y;
            tiles_of_warp[4 * t + 2] = p.z;
            entries_of_warp[t] = (base + g.lane) | tag;
          }
          held += popcount(kept);
          if (held - tested >= 32)
            test_tile(32, take);
        }
      };
      // The kept candidates left at the end of a row group's fluid or boundary rows.
      auto end_scan = [&](bool take) {
        if (held > tested)
          test_tile(held - tested, take);
        held = 0;
        tested = 0;
      };
      // The box of the points of the lanes that take the coming rows' hits.
      auto box_of = [&](bool take) {
        lo = g.min_each(take ? xi : Vec3<T>{far, far, far});
        hi = g.max_each(take ? xi : Vec3<T>{-far, -far, -far});
      };
      walk(g, mine, cx, cy, cz, near, scan, end_scan, box_of);
      if (mine)
        row.finish();
      return;
    }
#endif
    // One lane (the CPU; on the GPU a thread a particle, Warp false): candidates tested 32 at a
    // time, its hits appended as the warp's.
    std::uint32_t ring[kStageSlots];
    StagedRowAppender<1> row(out, i, ring);
    auto scan = [&](std::uint32_t from, std::uint32_t to, bool take, std::uint32_t tag,
                    const auto* pts) {
      for (std::uint32_t base = from; base < to; base += 32) {
        std::uint32_t hits = 0;
        for (std::uint32_t t = 0; t < 32 && base + t < to; ++t)
          hits |= (norm2(xi - position_of(pts[base + t])) < radius2 ? 1u : 0u) << t;
        // base + k never carries into the tag: indices stay below 2^31 - 32.
        append_to(row, take ? hits : 0u, [&](unsigned k) { return (base + k) | tag; });
      }
    };
    walk(
        g, mine, cx, cy, cz, near, scan, [](bool) {}, [](bool) {});
    if (mine)
      row.finish();
  }

  /// The walk both variants share: the group's lanes whose cells share a row (y, z) take that
  /// row's cells together, fluid then boundary, until every lane has walked its own.
  template <typename Scan, typename EndScan, typename BoxOf>
  KF_HD KF_INLINE void walk(exec::Lanes g, bool mine, int cx, int cy, int cz, bool near,
                            Scan&& scan, EndScan&& end_scan, BoxOf&& box_of) const {
    bool pending = mine;
    for (unsigned lead = g.first_set(pending); lead < g.size; lead = g.first_set(pending)) {
      // The lanes in the lead lane's row of cells, and the cells along x they span.
      const int ry = g.broadcast(cy, lead), rz = g.broadcast(cz, lead);
      const bool active = pending && cy == ry && cz == rz;
      const int x0 = g.min(active ? cx : cells.geo.nx), x1 = g.max(active ? cx : -1);
      box_of(active);
      cells.for_each_row_range(x0, x1, ry, rz, [&](std::uint32_t lo_, std::uint32_t hi_) {
        scan(lo_, hi_, active, 0u, xm);
      });
      end_scan(active);
      if (g.any(active && near)) {
        box_of(active && near);
        b.cells.for_each_row_range(x0, x1, ry, rz, [&](std::uint32_t lo_, std::uint32_t hi_) {
          scan(lo_, hi_, active && near, kBoundaryEntry, b.x);
        });
        end_scan(active && near);
      }
      pending = pending && !active;
    }
  }
};

} // namespace kf
