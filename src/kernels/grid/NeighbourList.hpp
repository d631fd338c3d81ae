#pragma once
// Per-particle lists of the neighbours within a radius, built from a NeighbourGrid and read by
// the passes that follow (SPH density and forces; the knit's self-contact and coupling).
//
// Why: on the GPU the lanes of a warp walk their grid candidates together, and with ~15% of
// candidates in range some lane almost always has a neighbour, so the whole warp runs the pair
// code for every candidate. A list pays the candidate walk once, with a cheap body (append),
// and the passes then run the pair code only for real neighbours. A build costs several passes
// (docs/PERFORMANCE.md), so the SPH lists pay when kept over steps with a skin (SphLists).
#include "kernels/exec/Algorithms.hpp"
#include "kernels/exec/PendingRead.hpp"
#include "kernels/grid/GridGeometry.hpp"

#include <type_traits>

namespace kf {

/// Slots per group in the lists' layout: 8 indices, one 32-byte memory sector.
constexpr std::uint32_t kListGroup = 8;
/// What a row's last group holds past its count (no particle: a reader that went past the
/// count would fault rather than read particle 0). Every builder pads it: the GPU's readers
/// load whole groups (ListView::for_each_group), so the padding is read, and left unwritten it
/// drew compute-sanitizer initcheck's reports on every pass over the walls' lists.
constexpr std::uint32_t kNoEntry = 0xFFFFFFFFu;

/// Calls each(e[u]) for the eight slots of a group when `whole`, without a test between them:
/// the compiler may then issue several entries' gathers before the first one's arithmetic (with
/// a test per entry, each entry's loads waited behind the previous entry's work: the SASS of the
/// forces pass). Else calls one(e[u]) for the first m.
template <typename F, typename G>
KF_HD KF_INLINE void visit_group(const std::uint32_t (&e)[kListGroup], std::uint32_t m, bool whole,
                                 F&& each, G&& one) {
  if (whole) {
    KF_UNROLL
    for (std::uint32_t u = 0; u < kListGroup; ++u)
      each(e[u]);
  } else {
    KF_UNROLL
    for (std::uint32_t u = 0; u < kListGroup; ++u)
      if (u < m)
        one(e[u]);
  }
}

/// Read-only view of the lists, passed by value into kernels. Slot k of particle i sits at
/// slot(i, k): slots go in groups of eight, group-major ((k / 8) * rows + i) * 8 + k % 8, so that
/// the lanes of a warp, each reading its own particle's next slots with 16-byte loads, read
/// one contiguous block (rows of one particle each made every lane's load its own transaction),
/// and the build writes whole 32-byte sectors (RowAppender, StagedRowAppender): with groups of
/// four, two lanes shared a sector and wrote their halves at different times, and a build in the
/// splash of the DualSPHysics column moved 3x the list's bytes through DRAM (ncu, H100).
template <typename T>
struct ListView {
  const std::uint32_t* count = nullptr;
  const std::uint32_t* list = nullptr;
  std::size_t capacity = 0; // slots per particle, a multiple of kListGroup
  std::size_t rows = 0;     // particles

  KF_HD KF_INLINE std::size_t slot(std::size_t i, std::size_t k) const {
    return ((k / kListGroup) * rows + i) * kListGroup + k % kListGroup;
  }
  /// Whether row i holds all its neighbours (build_for's rows may overflow).
  KF_HD KF_INLINE bool complete(std::size_t i) const { return count[i] <= capacity; }
  /// Calls g(e, m) for each group of row i in order: e holds the group's eight slots, the first
  /// m (1-8) of them neighbours (only a row's last group may hold fewer than eight).
  template <typename G>
  KF_HD KF_INLINE void for_each_group(std::size_t i, G&& g) const {
    const std::uint32_t c = count[i];
    for (std::uint32_t k = 0; k < c; k += kListGroup) {
      // A whole group, 32 bytes, with two back-to-back loads (the last group too: capacity is
      // whole groups). Read in halves one iteration apart, the second half often missed.
      std::uint32_t e[kListGroup];
      const std::uint32_t* p = list + slot(i, k);
      const std::uint32_t m = c - k < kListGroup ? c - k : kListGroup;
#if defined(__CUDA_ARCH__)
      // Streamed (evict first): each slot is read once per pass; the neighbours' data that
      // the pass gathers should keep the caches.
      const uint4 a = __ldcs(reinterpret_cast<const uint4*>(p));
      const uint4 b = __ldcs(reinterpret_cast<const uint4*>(p) + 1);
      e[0] = a.x, e[1] = a.y, e[2] = a.z, e[3] = a.w, e[4] = b.x, e[5] = b.y, e[6] = b.z,
      e[7] = b.w;
#else
      for (std::uint32_t u = 0; u < kListGroup; ++u)
        e[u] = u < m ? p[u] : 0u;
#endif
      g(e, m);
    }
  }
  /// Calls f(j) for the neighbours of i found at build time, in the grid's candidate order.
  template <typename F>
  KF_HD KF_INLINE void for_each_neighbour(std::size_t i, const Vec3<T>&, F&& f) const {
    for_each_group(i, [&](const std::uint32_t(&e)[kListGroup], std::uint32_t m) {
      visit_group(e, m, m == kListGroup, f, f);
    });
  }
  /// The same shared by `stride` lanes: this one takes every stride-th from `lane` on.
  template <typename F>
  KF_HD KF_INLINE void for_each_neighbour(std::size_t i, const Vec3<T>&, std::uint32_t lane,
                                          std::uint32_t stride, F&& f) const {
    for_each_slot(i, lane, stride, [&](std::size_t, std::uint32_t j) { f(j); });
  }
  /// The same with each entry's slot: f(slot(i, k), entry), for values kept per listed pair.
  template <typename F>
  KF_HD KF_INLINE void for_each_slot(std::size_t i, std::uint32_t lane, std::uint32_t stride,
                                     F&& f) const {
    const std::uint32_t c = count[i];
    for (std::uint32_t k = lane; k < c; k += stride) {
      const std::size_t s = slot(i, k);
      f(s, list[s]);
    }
  }
};

/// Where a builder writes: the mutable side of a ListView.
struct ListSink {
  std::uint32_t* count = nullptr;
  std::uint32_t* list = nullptr;
  std::size_t capacity = 0; // a multiple of kListGroup
  std::size_t rows = 0;
  /// Where slot k of row i goes (ListView::slot).
  KF_HD KF_INLINE std::uint32_t* slot(std::size_t i, std::size_t k) const {
    return list + ((k / kListGroup) * rows + i) * kListGroup + k % kListGroup;
  }
};

/// The same interface over a cell grid: every candidate of the cells around x (f filters).
template <typename T>
struct CellNeighbours {
  CellView<T> cells;
  template <typename F>
  KF_HD KF_INLINE void for_each_neighbour(std::size_t, const Vec3<T>& x, F&& f) const {
    cells.for_each_candidate(x, f);
  }
};

/// Every candidate within the radius may pair (the SPH lists).
struct AnyPair {
  KF_HD KF_INLINE bool operator()(std::size_t, std::uint32_t) const { return true; }
};

namespace list_detail {

/// Writes four indices with one 16-byte store on the GPU (p is 16-byte aligned).
KF_HD KF_INLINE void store4(std::uint32_t* p, std::uint32_t a, std::uint32_t b, std::uint32_t c,
                            std::uint32_t d) {
#if defined(__CUDA_ARCH__)
  // Streamed (evict first): the list is read once per pass much later, while the particle data
  // the build gathers should stay in L2 (stage 4's ncu: 70% L2 hits in a build).
  __stcs(reinterpret_cast<uint4*>(p), make_uint4(a, b, c, d));
#else
  p[0] = a;
  p[1] = b;
  p[2] = c;
  p[3] = d;
#endif
}

} // namespace list_detail

/// Appends one particle's neighbours to its row while they fit and counts all of them (a count
/// over the capacity marks an overflow). Neighbours are held in registers and written eight at
/// a time, a whole group: lanes of a warp find neighbours at different candidates, so
/// single-index stores each became their own memory transaction, and the build cost 2.5x a
/// density pass (measured). For one lane a row (ListBuilder); the SPH chunk builder, whose lanes
/// append at different rates, stages its rows in shared memory instead (StagedRowAppender).
class RowAppender {
public:
  KF_HD KF_INLINE RowAppender(const ListSink& out, std::size_t i) : out_(out), i_(i) {}
  KF_HD KF_INLINE void push(std::uint32_t j) {
    // Selects, not a switch: the lanes of a warp push at different slots, and a switch made
    // them take different branches. A full quad waits in q until the group's second one.
    const std::uint32_t s = c_ & 3u;
    b0_ = s == 0 ? j : b0_;
    b1_ = s == 1 ? j : b1_;
    b2_ = s == 2 ? j : b2_;
    if (s == 3) {
      if ((c_ & 4u) == 0) {
        q0_ = b0_;
        q1_ = b1_;
        q2_ = b2_;
        q3_ = j;
      } else if (c_ < out_.capacity) {
        std::uint32_t* g = group(c_);
        list_detail::store4(g, q0_, q1_, q2_, q3_);
        list_detail::store4(g + 4, b0_, b1_, b2_, j);
      }
    }
    ++c_;
  }
  /// Writes the last 1-7 neighbours, the group padded with kNoEntry (two 16-byte stores, the
  /// whole sector), and the count.
  KF_HD KF_INLINE void finish() {
    const std::uint32_t tail = c_ & ~(kListGroup - 1); // the group not yet written
    if (tail < out_.capacity && tail < c_) {
      std::uint32_t* g = group(tail);
      const std::uint32_t r = c_ - tail; // 1-7; b holds the last r % 4, q a full quad if r >= 4
      const std::uint32_t e0 = b0_, e1 = r % 4 > 1 ? b1_ : kNoEntry,
                          e2 = r % 4 > 2 ? b2_ : kNoEntry;
      if (r >= 4) {
        list_detail::store4(g, q0_, q1_, q2_, q3_);
        list_detail::store4(g + 4, r > 4 ? e0 : kNoEntry, e1, e2, kNoEntry);
      } else {
        list_detail::store4(g, e0, e1, e2, kNoEntry);
        list_detail::store4(g + 4, kNoEntry, kNoEntry, kNoEntry, kNoEntry);
      }
    }
    out_.count[i_] = c_;
  }

private:
  KF_HD KF_INLINE std::uint32_t* group(std::uint32_t k) const {
    return out_.slot(i_, k & ~(kListGroup - 1));
  }
  ListSink out_;
  std::size_t i_;
  std::uint32_t c_ = 0, b0_ = 0, b1_ = 0, b2_ = 0, q0_ = 0, q1_ = 0, q2_ = 0, q3_ = 0;
};

namespace list_detail {

/// One query point's neighbours among one grid's candidates. P: Vec3 or a packed Vec4.
template <typename T, typename P, typename Pred>
struct ListBuilder {
  const Vec3<T>* q;             // query points
  const P* x;                   // candidates, in `cells`' order
  const std::uint32_t* active;  // nullptr: every query point; else those with active[i] != 0
  const std::uint8_t* occupied; // per cell of `cells`: CellView::may_find (null: walk all)
  CellView<T> cells;
  T radius2;
  ListSink out;
  Pred keep; // keep(i, j): whether candidate j may pair with query i at all

  KF_HD void operator()(std::size_t i) const {
    RowAppender row(out, i);
    if (!active || active[i]) {
      const Vec3<T> xi = q[i];
      if (cells.may_find(occupied, xi))
        cells.for_each_candidate(xi, [&](std::uint32_t j) {
          if (norm2(xi - position_of(x[j])) < radius2 && keep(i, j))
            row.push(j);
        });
    }
    row.finish();
  }
};

/// ListBuilder with a group of lanes a query point (for_each_lanes): the lanes test a row's
/// candidates side by side, eight or so at a time, and append those in range in the walk's order
/// (a ballot: each lane's slot is the count so far plus its hits below it), so the row is the
/// one ListBuilder writes. For query points with many candidates and few points (a coarse
/// fluid's particles over a fine knit), whose one-lane walk was the whole pass's latency.
template <typename T, typename P, typename Pred>
struct LaneListBuilder {
  ListBuilder<T, P, Pred> b;

  KF_HD void operator()(std::size_t i, exec::Lanes g) const {
    std::uint32_t c = 0;
    if (!b.active || b.active[i]) {
      const Vec3<T> xi = b.q[i];
      if (b.cells.may_find(b.occupied, xi))
        b.cells.for_each_row_range(xi, [&](std::uint32_t lo, std::uint32_t hi) {
          for (std::uint32_t base = lo; base < hi; base += g.size) { // the same trips on every lane
            const std::uint32_t j = base + g.lane;
            const bool hit = j < hi && norm2(xi - position_of(b.x[j])) < b.radius2 && b.keep(i, j);
            const unsigned bits = g.ballot(hit);
            const std::uint32_t k = c + g.count_below(bits);
            if (hit && k < b.out.capacity)
              *b.out.slot(i, k) = j;
            c += popcount(bits);
          }
        });
    }
    if (g.lane == 0) { // the last group's rest padded (RowAppender::finish)
      b.out.count[i] = c;
      for (std::uint32_t k = c; k % kListGroup != 0 && k < b.out.capacity; ++k)
        *b.out.slot(i, k) = kNoEntry;
    }
  }
};

} // namespace list_detail

template <typename T>
class NeighbourList {
public:
  /// name: its buffers' labels ("fluid.lists": "fluid.lists.list", ...; exec::peak_by_label).
  explicit NeighbourList(exec::Backend b, const char* name = "neighbours");

  /// Lists, for each of the n points x (sorted as `cells` describes), every j with
  /// |x_i - x_j|^2 < radius2 (i itself included), in the order the cell walk meets them. The
  /// capacity grows (and the build repeats) until the densest particle fits.
  void build(const exec::Exec& ex, const Vec3<T>* x, std::size_t n, const CellView<T>& cells,
             T radius2);
  /// The same with any builder: make(sink) returns a functor that fills row i of the sink
  /// (RowAppender) when called with i, for i < n. The capacity grows until every row fits.
  /// A template that launches: call it from a file under src/kernels (compiled by nvcc).
  /// A functor taking (i, exec::Lanes) runs with G lanes per row (for_each_lanes).
  template <unsigned G = 1, typename Make>
  void build_with(const exec::Exec& ex, std::size_t n, Make&& make, const char* label) {
    build_rows(ex, n, [&](const ListSink& out) {
      auto f = make(out);
      if constexpr (std::is_invocable_v<decltype(f), std::size_t, exec::Lanes>)
        exec::for_each_lanes<G>(ex, n, f, label);
      else
        exec::for_each(ex, n, f, label);
    });
  }
  /// The same with a functor f(first, exec::Lanes) that fills the rows of a chunk of G
  /// consecutive particles, one a lane (exec::for_each_chunk; SphChunkListBuilder).
  template <unsigned G, typename Make>
  void build_chunked(const exec::Exec& ex, std::size_t n, Make&& make, const char* label) {
    build_rows(ex, n,
               [&](const ListSink& out) { exec::for_each_chunk<G>(ex, n, make(out), label); });
  }
  /// build_chunked without waiting: one build at the present capacity, whose check is read back
  /// behind it. settle() then waits for the check: false (and a larger capacity) when some row
  /// overflowed and the build must be repeated. The lists are not to be read before that.
  template <unsigned G, typename Make>
  void start_chunked(const exec::Exec& ex, std::size_t n, Make&& make, const char* label) {
    launch_rows(n, [&](const ListSink& out) { exec::for_each_chunk<G>(ex, n, make(out), label); });
    start_fit(ex, n);
  }
  bool settle() { return finish_fit(); }
  bool settled() const { return !most_read_.pending(); }
  /// Lists, for each of n query points q (the inactive ones, active[i] == 0, get none), the
  /// candidates j of `cells` (positions x) with |q_i - x_j|^2 < radius2, in the order the cell
  /// walk meets them. Fixed capacity and no read on the host: a count over the capacity marks a
  /// row that overflowed (ListView::complete is false; its user walks the cells instead).
  /// keep(i, j) may drop candidates that can never pair (the knit's rest-mesh exclusion).
  /// x: positions (Vec3) or packed (x, w) pairs (Vec4). `occupied` (NeighbourGrid::
  /// occupied_around of `cells`, or null) lets query points with no candidate around skip
  /// their walk.
  /// G > 1: G lanes a query point (LaneListBuilder; the same lists), for few query points with
  /// many candidates each.
  template <unsigned G = 1, typename P, typename Pred = AnyPair>
  void build_for(const exec::Exec& ex, const Vec3<T>* q, const std::uint32_t* active, std::size_t n,
                 const P* x, const CellView<T>& cells, T radius2, std::uint32_t capacity,
                 Pred keep = {}, const std::uint8_t* occupied = nullptr,
                 const char* label = "neighbours.build_for") {
    capacity_ = whole_groups(capacity);
    size_rows(n);
    const list_detail::ListBuilder<T, P, Pred> b{q,     x,       active,  occupied,
                                                 cells, radius2, sink(n), keep};
    if constexpr (G > 1)
      exec::for_each_lanes<G>(ex, n, list_detail::LaneListBuilder<T, P, Pred>{b}, label);
    else
      exec::for_each(ex, n, b, label);
  }
  /// For build_for's lists, whose capacity the caller chooses: the largest count of the last
  /// build (rows past the capacity counted whole), read back behind it. start_most() queues
  /// the read; read_most() waits for it (the last reading where none is queued).
  void start_most(const exec::Exec& ex) { start_fit(ex, count_.size()); }
  std::uint32_t read_most() {
    finish_fit();
    return most_;
  }
  ListView<T> view() const { return {count_.data(), list_.data(), capacity_, count_.size()}; }
  /// Slots per particle now; most neighbours of one particle at the last build (build,
  /// build_with).
  std::uint32_t capacity() const { return capacity_; }
  std::uint32_t most() const { return most_; }
  /// The first build's capacity, kept while every row fits it.
  static constexpr std::uint32_t kFirstCapacity = 32;
  /// The capacity a build grows to when its densest row holds `most` (more than it had): room
  /// for the density to rise before the next growth, in whole groups.
  static constexpr std::uint32_t capacity_for(std::uint32_t most) {
    return whole_groups(most + most / 4 + kListGroup);
  }
  /// k slots rounded up to whole groups.
  static constexpr std::uint32_t whole_groups(std::uint32_t k) {
    return (k + kListGroup - 1) / kListGroup * kListGroup;
  }
  /// What the builds settle on from the first for rows of `most` at most (`knitflow plan`).
  static constexpr std::uint32_t settled_capacity(std::uint32_t most) {
    return most <= kFirstCapacity ? kFirstCapacity : capacity_for(most);
  }
  std::size_t bytes() const { return count_.capacity_bytes() + list_.capacity_bytes(); }

private:
  ListSink sink(std::size_t n) { return {count_.data(), list_.data(), capacity_, n}; }
  /// n rows at the present capacity. The rows' room grows snugly (the rows of a rank's owned
  /// and ghost particles, whose count moves a little from one build to the next) and the
  /// lists' room is the rows' at that width: grown geometrically, the largest buffer a fluid
  /// rank holds stood up to half empty. Every caller writes every row after this, so the
  /// lists' contents need not be kept where their room changes.
  void size_rows(std::size_t n) {
    count_.resize_snug(n);
    const std::size_t room = std::size_t(capacity_) * count_.capacity();
    if (list_.capacity() > room + room / 8) // rows narrowed (build_for): the rest freed
      list_.release();
    list_.reserve_discarding(room);
    list_.resize(std::size_t(capacity_) * n);
  }
  /// launch(sink) fills every row, at the present capacity (32 at first).
  template <typename Launch>
  void launch_rows(std::size_t n, Launch&& launch) {
    if (capacity_ == 0)
      capacity_ = kFirstCapacity;
    size_rows(n);
    launch(sink(n));
  }
  /// launch_rows, repeated with a larger capacity until every row fits.
  template <typename Launch>
  void build_rows(const exec::Exec& ex, std::size_t n, Launch&& launch) {
    do
      launch_rows(n, launch);
    while (!fits(ex, n));
  }
  /// Reads the largest count; false (and a larger capacity) when some row overflowed.
  bool fits(const exec::Exec& ex, std::size_t n);
  /// fits() in two halves: queue the largest count's read, then (after more work was queued)
  /// wait for it.
  void start_fit(const exec::Exec& ex, std::size_t n);
  bool finish_fit();

  exec::DeviceBuffer<std::uint32_t> count_, list_;
  std::uint32_t capacity_ = 0, most_ = 0;
  exec::DeviceBuffer<std::uint32_t> most_dev_;
  exec::PendingRead<std::uint32_t> most_read_;
};

} // namespace kf
