#include "kernels/sph/SphLists.hpp"

#include "kernels/sph/SphNeighbours_K.hpp"

#include <algorithm>
#include <cmath>
#include <string>

namespace kf {

namespace {

/// What the rule needs of particle i's displacement d since the build: |d|^2 and the six
/// one-sided components (a NaN reads as the largest value, so it rebuilds and then shows); then
/// the cell of its build position, as (cx, cy, cz, nx - 1 - cx, ny - 1 - cy, nz - 1 - cz): their
/// maxima give the box of the cells the build filled (exact in T: cell counts stay below 2^24).
template <typename T>
struct Displacement {
  const Vec3<T>* x;
  const Vec3<T>* x0;
  GridGeometry<T> geo;
  KF_HD KF_INLINE exec::Maxima<T, 13> operator()(std::size_t i) const {
    const Vec3<T> d = x[i] - x0[i];
    const T d2 = norm2(d);
    int cx, cy, cz;
    geo.coords(x0[i], cx, cy, cz);
    const T c[6] = {
        T(cx), T(cy), T(cz), T(geo.nx - 1 - cx), T(geo.ny - 1 - cy), T(geo.nz - 1 - cz)};
    if (!(d2 == d2)) {
      const T big = std::numeric_limits<T>::max();
      return {{big, big, big, big, big, big, big, c[0], c[1], c[2], c[3], c[4], c[5]}};
    }
    const T zero = T(0);
    return {{d2, d.x > zero ? d.x : zero, d.x < zero ? -d.x : zero, d.y > zero ? d.y : zero,
             d.y < zero ? -d.y : zero, d.z > zero ? d.z : zero, d.z < zero ? -d.z : zero, c[0],
             c[1], c[2], c[3], c[4], c[5]}};
  }
};

/// A box of cells [lo, lo + n) of a grid, walked by a linear index k (x fastest); the boxes of
/// displacements are held by k, over this region only.
struct CellRegion {
  int lo[3], n[3];
  KF_HD KF_INLINE std::size_t count() const {
    return std::size_t(n[0]) * std::size_t(n[1]) * std::size_t(n[2]);
  }
  template <typename T>
  KF_HD KF_INLINE std::size_t cell(std::size_t k, const GridGeometry<T>& geo) const {
    const std::size_t nx = std::size_t(n[0]), nxy = nx * std::size_t(n[1]);
    return geo.linear(lo[0] + int(k % nx), lo[1] + int(k / nx % std::size_t(n[1])),
                      lo[2] + int(k / nxy));
  }
};

template <typename T>
using Box = typename SphLists<T>::Box;

/// The box of the displacements since the build of the particles the build put in the region's
/// cell k; the fluid keeps its order until the next build. The group's lanes split the
/// cell's particles (one thread walking ~50 in a row waited on each load in turn); min and max
/// are exact, so the box does not depend on the split.
template <typename T>
struct CellDisplacementBox {
  CellView<T> cells;
  CellRegion region; // the cells computed (index k: region.cell(k))
  const Vec3<T>* x;
  const Vec3<T>* x0;
  Box<T>* out;
  KF_HD void operator()(std::size_t k, exec::Lanes g) const {
    const std::size_t c = region.cell(k, cells.geo);
    Box<T> b = Box<T>::empty();
    const std::uint32_t r = cells.rank[c];
    for (std::uint32_t i = cells.start[r] + g.lane; i < cells.end[r]; i += g.size)
      b.add(Vec3<T>(x[i] - x0[i]));
    b.lo = g.min_each(b.lo);
    b.hi = g.max_each(b.hi);
    if (g.lane == 0)
      out[k] = b;
  }
};

/// The union of the boxes of the cells within `reach` of the region's cell k along one axis (0,
/// 1, 2): three passes, one an axis, give the union over the (2 reach + 1)^3 cells around it.
/// Only the region's cells are read and written: the cells outside it hold no particle of the
/// build.
template <typename T>
struct SpreadBoxes {
  CellRegion region;
  int axis;
  int reach;
  const Box<T>* in;
  KF_HD KF_INLINE Box<T> around(std::size_t k) const {
    const std::size_t nx = std::size_t(region.n[0]), nxy = nx * std::size_t(region.n[1]);
    const int at = axis == 0   ? int(k % nx)
                   : axis == 1 ? int(k / nx % std::size_t(region.n[1]))
                               : int(k / nxy);
    const int last = region.n[axis] - 1;
    const std::size_t stride = axis == 0 ? 1 : axis == 1 ? nx : nxy;
    const int j0 = at - reach > 0 ? at - reach : 0, j1 = at + reach < last ? at + reach : last;
    const std::size_t k0 = k - std::size_t(at - j0) * stride;
    Box<T> u = in[k0];
    for (int j = j0 + 1; j <= j1; ++j)
      u.add(in[k0 + std::size_t(j - j0) * stride]);
    return u;
  }
};

template <typename T>
struct SpreadInto {
  SpreadBoxes<T> s;
  Box<T>* out;
  KF_HD void operator()(std::size_t k) const { out[k] = s.around(k); }
};

/// The last axis's pass, reduced: the squared diagonal of cell c's union box (0 when empty).
template <typename T>
struct SpreadDiagonal {
  SpreadBoxes<T> s;
  KF_HD KF_INLINE exec::Maxima<T, 1> operator()(std::size_t k) const {
    const Box<T> u = s.around(k);
    const T zero = T(0);
    const T dx = u.hi.x - u.lo.x, dy = u.hi.y - u.lo.y, dz = u.hi.z - u.lo.z;
    const T ex = dx > zero ? dx : zero, ey = dy > zero ? dy : zero, ez = dz > zero ? dz : zero;
    return {{ex * ex + ey * ey + ez * ez}};
  }
};

/// The list builder of a build's inputs, for each sink the lists hand it.
template <typename T, bool Warp, typename Built>
auto chunk_builders(const Built& k) {
  return [k](const ListSink& out) {
    return SphChunkListBuilder<T, Warp>{k.f.xm, k.cells, k.b, k.r2, out, k.f.n};
  };
}

/// Below this many fluid particles a thread builds a particle's row, above it a warp 32 rows
/// (the same rows; SphChunkListBuilder). One H200, the pour (64,000 fluid, a few thousand
/// spread over the knit late in the run): a build 447 -> 85 us over the whole run, the run
/// 14.98 / 15.22 -> 13.91 / 14.05 s; at its start (64k particles in a block) 83 against 91 us,
/// and a warp's walk of dense rows is what makes the millions' builds fast (P4 stage 8).
constexpr std::size_t kThreadRowsBelow = 65536;

/// Builds (or starts building) the lists for k's particles, a row a lane or 32 rows a warp.
template <typename T, bool Warp, typename Lists, typename Built>
void build_rows_by(const exec::Exec& ex, Lists& lists, const Built& k, bool wait) {
  constexpr unsigned lanes = Warp ? 32 : 1;
  if (wait)
    lists.template build_chunked<lanes>(ex, k.f.n, chunk_builders<T, Warp>(k), "neighbours.build");
  else
    lists.template start_chunked<lanes>(ex, k.f.n, chunk_builders<T, Warp>(k), "neighbours.build");
}

template <typename T, typename Lists, typename Built>
void build_rows(const exec::Exec& ex, Lists& lists, const Built& k, bool wait) {
  if (k.f.n < kThreadRowsBelow)
    build_rows_by<T, false>(ex, lists, k, wait);
  else
    build_rows_by<T, true>(ex, lists, k, wait);
}

} // namespace

template <typename T>
SphLists<T>::SphLists(exec::Backend b, T skin)
    : skin_(skin), lists_(b, "fluid.lists"), walls_(b, "walls.lists"), x0_(b, 0, "fluid.listed_x"),
      moved_(b, 14, "fluid.moved"), read_(b, 14, "fluid.moved"), box_(b, 0, "fluid.moved_box"),
      spread_(b, 0, "fluid.moved_box") {}

template <typename T>
void SphLists<T>::build(const exec::Exec& ex, FluidSet<T>& f, const CellView<T>& cells,
                        const BoundaryNeighbours<T>& b, T h, const std::uint8_t* fluid_near) {
  const std::size_t n = f.size();
  // Under 2^31 - 32: a 32-candidate block's last index must not carry into the boundary tag.
  if (n + 32 >= kBoundaryEntry || b.n + 32 >= kBoundaryEntry)
    throw Error("SPH neighbour lists: " + std::to_string(n) + " fluid and " + std::to_string(b.n) +
                " boundary particles; fewer than 2^31 - 32 of each fit a list");
  const T r2 = (h + skin_) * (h + skin_);
  // The builder walks both grids from one cell's coordinates.
  if (b.n > 0 && !cells.geo.same_cells(b.cells.geo))
    throw Error("SPH neighbour lists: the boundary grid's cells differ from the fluid grid's; "
                "both must cover the same domain with the same cell");
  // A warp per 32 particles (SphChunkListBuilder). Measured on an H100, column dp 3.5 mm, mean
  // per build over its first 0.35 s (1,318 builds): 6.6 ms with 16 lanes a particle and ballot
  // appends, 6.6 with this builder and 4-slot groups, 4.2 with 8-slot groups.
  const FluidView<T> fv = f.view(); // xm: FluidSet::reorder wrote it
  built_ = {fv, cells, b, r2};
  // The first build waits for its rows to fit (once a run: at the first 32 slots most rows
  // overflow, and settle() would build them again all the same).
  build_rows<T>(ex, lists_, built_, lists_.capacity() == 0);
  if (skin_ > T(0)) {
    x0_.resize(n);
    x0_.copy_from(f.x, n);
    bound_ = T(0);
    pair_ = T(0);
    cells_ = cells;
    walls_listed_ = b.n > 0;
    if (walls_listed_)
      build_walls(ex, b, cells, r2, fluid_near);
  }
}

template <typename T>
void SphLists<T>::build_walls(const exec::Exec& ex, const BoundaryNeighbours<T>& b,
                              const CellView<T>& cells, T r2, const std::uint8_t* fluid_near) {
  // Rows in the walk's order, which the walls' pass walked: its sums stay those of the walk.
  const auto list = [&](std::uint32_t width) {
    walls_.build_for(ex, b.x, nullptr, b.n, built_.f.xm, cells, r2, width, AnyPair{}, fluid_near,
                     "neighbours.walls");
  };
  // The walls' rows as wide as their densest: a wall particle's fluid lies on one side, about
  // half a fluid row (the column's walls held ~1 GB at the fluid rows' width). The first build
  // lists them narrow, as the fluid's first build does, reads how wide they need to be and
  // lists them again at that width (the narrow lists freed first: the peak is the wide ones);
  // later builds grow them from the reading queued behind the build before. A row that
  // overflows meanwhile is walked instead (ListView::complete).
  if (walls_width_ == 0) {
    constexpr std::uint32_t first = NeighbourList<T>::kFirstCapacity;
    list(first);
    walls_.start_most(ex);
    walls_width_ = NeighbourList<T>::settled_capacity(walls_.read_most());
    if (walls_width_ != first)
      list(walls_width_);
  } else {
    const std::uint32_t most = walls_.read_most();
    if (most > walls_width_)
      walls_width_ = NeighbourList<T>::capacity_for(most);
    list(walls_width_);
  }
  walls_.start_most(ex);
  ++walls_builds_;
}

template <typename T>
void SphLists<T>::settle(const exec::Exec& ex) {
  if (lists_.settle())
    return;
  // A row overflowed (the capacity has grown): build again, waiting this time. The gather
  // copies xm still hold the positions of the build (the passes since wrote none).
  build_rows<T>(ex, lists_, built_, true);
}

template <typename T>
bool SphLists<T>::stale_after(const exec::Exec& ex, const FluidSet<T>& f, T motion, bool force,
                              const std::function<void()>& meanwhile) {
  bool rebuild = !(skin_ > T(0)) || force || x0_.size() != f.size();
  if (combine_) { // one rank's reason is every rank's: the readings below are collective
    T any = rebuild ? T(1) : T(0);
    combine_(&any, 1);
    rebuild = any > T(0);
  }
  if (rebuild)
    return true;
  bound_ += motion;
  pair_ += T(2) * motion;
  if (bound_ <= T(0.5) * skin_ || (bound_ <= skin_ && pair_ <= skin_))
    return false; // the rules hold on the host's bounds alone: no need to look
  const std::size_t n = f.size();
  exec::fill(ex, moved_, T(0), "fluid.moved");
  exec::max_into_each<T, 13>(ex, n, Displacement<T>{f.x.data(), x0_.data(), cells_.geo},
                             moved_.data(), "fluid.moved");
  read_.start(moved_.data());
  if (meanwhile)
    meanwhile();
  const auto reading = read_.wait();
  std::vector<T> m(reading.begin(), reading.end());
  if (combine_)
    combine_(m.data(), 7);
  const double s = double(skin_);
  const double largest = std::sqrt(double(m[0]));
  const double bx = double(m[1]) + double(m[2]), by = double(m[3]) + double(m[4]),
               bz = double(m[5]) + double(m[6]);
  const double diagonal = std::sqrt(bx * bx + by * by + bz * bz);
  double pair = std::min(2 * largest, diagonal);
  double local = std::numeric_limits<double>::infinity();
  // The local bound only when the global ones fail and could be rescued (a second reading:
  // its four passes over the cells cost more than the pour's whole step saves otherwise).
  if (largest <= s && pair > s) {
    const int reach = cells_.span; // around the pair's midpoint cell (SphLists.hpp)
    // Over the box of the cells the build filled, widened by the reach: outside it every cell's
    // union is empty, so the largest diagonal is the whole grid's (the pour's fluid fills a
    // fraction of its domain's cells once it has run off).
    const GridGeometry<T>& geo = cells_.geo;
    const int dims[3] = {geo.nx, geo.ny, geo.nz};
    CellRegion region{};
    for (int a = 0; a < 3; ++a) {
      const int lo = dims[a] - 1 - int(m[10 + a]), hi = int(m[7 + a]); // this rank's box
      region.lo[a] = std::max(lo - reach, 0);
      region.n[a] = std::min(hi + reach, dims[a] - 1) - region.lo[a] + 1;
    }
    const std::size_t cells = n > 0 ? region.count() : 0;
    // The boxes over the region only, taken when this bound first runs (a run whose lists the
    // global bounds keep alone never takes them) and grown snugly; every box is written again
    // (the pour's boxes over its whole grid held 48 MB).
    box_.resize_snug_discarding(cells);
    spread_.resize_snug_discarding(cells);
    exec::for_each_lanes<8>(
        ex, cells, CellDisplacementBox<T>{cells_, region, f.x.data(), x0_.data(), box_.data()},
        "fluid.moved_box");
    exec::for_each(ex, cells, SpreadInto<T>{{region, 0, reach, box_.data()}, spread_.data()},
                   "fluid.moved_box");
    exec::for_each(ex, cells, SpreadInto<T>{{region, 1, reach, spread_.data()}, box_.data()},
                   "fluid.moved_box");
    exec::max_into_each<T, 1>(ex, cells, SpreadDiagonal<T>{{region, 2, reach, box_.data()}},
                              moved_.data() + 13, "fluid.moved_box");
    read_.start(moved_.data());
    m[7] = read_.wait()[13];
    if (combine_)
      combine_(m.data() + 7, 1);
    local = std::sqrt(double(m[7]));
    pair = std::min(pair, local);
  }
  bound_ = static_cast<T>(largest);
  pair_ = static_cast<T>(pair);
  last_largest_ = bound_;
  last_pair_ = pair_;
  last_local_ = static_cast<T>(local);
  const bool holds = largest <= s && pair <= s;
  if (!holds)
    ++(largest > s ? ends_.far : ends_.sheared);
  return !holds;
}

template class SphLists<float>;
template class SphLists<double>;

} // namespace kf
