#pragma once
// The fluid's neighbour lists (solver.neighbour_list): for each fluid particle, its fluid and
// then its boundary neighbours within the support plus a skin s. With a skin the lists, the
// fluid's order and its grid are kept over steps (a Verlet list) while both hold:
//  - every particle is within s of where it was listed: a boundary particle (which stays put)
//    within h now was within h + s then, and a walk of the grid, whose cells reach h + s, still
//    finds every particle within h of a point;
//  - two fluid particles closed in by at most s: |d_i - d_j| <= s for every pair that could
//    have come within h. Three bounds, the smallest kept:
//    - 2 max |d_i|;
//    - the diagonal of the box of all displacements d_i (origin included): a fluid that moves
//      together (a falling column) keeps its lists (the dam break test, skin 0.15, sorts 11
//      times in 300 steps, not 19);
//    - the local one: the largest diagonal, over the cells m of the grid of the build, of the
//      box of the displacements of the particles listed in the cells within span of m (the
//      cells' edge is (h + s) / span). A pair within h now was within h + 2s < 2 (h + s) when
//      listed (every |d| <= s), so its two cells a, b are within 2 span of each other along
//      each axis; the cell m halfway, m = floor((a + b) / 2) per axis, is within span of both,
//      so both displacements lie in m's box. A flow's neighbours move alike even where it is
//      fast: the lists last until the flow shears by s, not until its fastest particle has moved
//      s / 2 (the column's surge: docs/PERFORMANCE.md). Around the midpoint the boxes span 3
//      cells a side, not the 5 around the pair's first cell: a bound 5/3 tighter.
// With a skin the walls get lists too (walls()): for each boundary particle, the fluid within
// h + s at the build, for the walls' pass (boundary_pressure). The first rule keeps them: a fluid
// particle within h of a wall particle now was within h + s of it then. The pass otherwise walks
// the ~1,700 grid candidates of each wet wall particle every step, ~85% of them out of range.
#include "kernels/exec/PendingRead.hpp"
#include "kernels/grid/NeighbourList.hpp"
#include "kernels/sph/Sph.hpp"

#include <functional>
#include <limits>
#include <vector>

namespace kf {

/// SphLists<T>::footprint's: bytes a fluid particle and a boundary particle.
struct SphListsFootprint {
  double per_fluid = 0, per_boundary = 0;
};

template <typename T>
class SphLists {
public:
  /// skin 0: lists of the support only, to be built again every step.
  SphLists(exec::Backend b, T skin);

  /// Lists every particle of f (sorted as `cells` describes) against f and the boundary b,
  /// within the support h plus the skin, and takes the positions now as the reference. Reads
  /// the neighbour copy f.xm = (x, m), which the sort's FluidSet::reorder wrote. The
  /// check that every row fitted is read back behind the build: settle() waits for it (and
  /// builds again, larger, where one did not) and must come before the lists are read; work
  /// queued in between keeps the GPU busy while the host waits. With a skin, also lists the
  /// fluid around each boundary particle of b (walls()); `fluid_near` (per cell of `cells`,
  /// NeighbourGrid::occupied_around; null: walk every cell) skips the dry ones. b's order must
  /// then hold until the next build (a sort of the boundary calls forget_walls()).
  void build(const exec::Exec& ex, FluidSet<T>& f, const CellView<T>& cells,
             const BoundaryNeighbours<T>& b, T h, const std::uint8_t* fluid_near = nullptr);
  void settle(const exec::Exec& ex);
  /// After the fluid moved by at most `motion` since the last call (a true bound; infinity:
  /// unknown), whether the lists may have missed a pair and must be built again. Reads the
  /// device only when the host's bounds (on max |d| and on the pairs' |d_i - d_j|, each grown
  /// by the motion since the last reading) leave the rules unsure. `force`: true, unasked.
  /// `meanwhile`, when given, is called once the reading is queued and before the host waits
  /// for it (work for the GPU that holds whatever the answer); it is not called when no reading
  /// is needed.
  bool stale_after(const exec::Exec& ex, const FluidSet<T>& f, T motion, bool force,
                   const std::function<void()>& meanwhile = {});
  /// On N ranks, each holding its own fluid and ghosts (domain/RankExchange): `combine`
  /// replaces k readings by their largest over the job (in place, collective; stale_after then
  /// is too), so that every rank takes the same decision at the same step, the one a single rank
  /// holding all the fluid would take from the first seven (largest displacement, the
  /// displacements' box). The local bound (the eighth value combined) is the largest over the
  /// ranks of each rank's own: a bound for the pairs each rank lists (all their partners are its
  /// owned or ghost particles).
  void combine_readings(std::function<void(T*, int)> combine) { combine_ = std::move(combine); }
  /// The fluid's arrays were replaced (a restart): the next stale_after says so.
  void forget() {
    x0_.resize(0);
    forget_walls();
  }
  /// The boundary was sorted: the walls' rows no longer match it (walls() is empty until the
  /// next build).
  void forget_walls() { walls_listed_ = false; }
  /// Restart: with a skin, the positions the lists were built for (empty before the first
  /// build) and the host's bounds since. A run continued from a snapshot builds its lists for
  /// x0 again (the fluid's order is theirs) and takes the bounds, so that it keeps them, and
  /// builds anew, when the uninterrupted run did: lists built at another step sum the same
  /// pairs in another order (and reorder the fluid).
  struct State {
    std::vector<Vec3<T>> x0;
    T bound = std::numeric_limits<T>::infinity(), pair = std::numeric_limits<T>::infinity();
  };
  State state() const { return {x0_.to_host(), bound_, pair_}; }
  /// After build() for the state's x0: the bounds the run had reached since that build.
  void restore(const State& s) {
    bound_ = s.bound;
    pair_ = s.pair;
  }
  /// The walls' lists: row k, boundary particle k's fluid candidates (ListView::complete false
  /// where a row overflowed its capacity: walk the cells); empty (count null) without them.
  ListView<T> walls() const { return walls_listed_ ? walls_.view() : ListView<T>{}; }
  /// The walls' builds so far: a pass that wrote every wall since the last one may skip the dry
  /// (boundary_pressure's dry_written).
  std::uint64_t walls_builds() const { return walls_builds_; }

  /// Why the rules ended the lists, counted over the run (stale_after's readings that answered
  /// true; forced builds are not counted).
  struct Ends {
    std::uint64_t far = 0;     // a particle moved farther than s
    std::uint64_t sheared = 0; // none did, but pairs may have closed in by more than s
  };
  const Ends& ends() const { return ends_; }

  /// The lists (after settle()).
  ListView<T> view() const {
    if (!lists_.settled())
      throw Error("SPH neighbour lists read before their build was settled (SphLists::settle)");
    return lists_.view();
  }
  T skin() const { return skin_; }
  /// With a skin: the positions the lists were built for (the fluid's order now; null before
  /// the first build, or for another count) and a bound on every particle's displacement since,
  /// the host's or the last reading's (stale_after; 0 after a build). The knit's coupling builds
  /// its lists for these positions too (FluidAnchor).
  const Vec3<T>* listed_x(std::size_t n) const {
    return skin_ > T(0) && x0_.size() == n ? x0_.data() : nullptr;
  }
  T displacement_bound() const { return bound_; }
  std::uint32_t capacity() const { return lists_.capacity(); }
  std::size_t bytes() const {
    return lists_.bytes() + walls_.bytes() + x0_.capacity_bytes() + moved_.capacity_bytes() +
           box_.capacity_bytes() + spread_.capacity_bytes();
  }
  /// What such lists hold once built for fluid rows of `most` particles at most and wall rows
  /// of `walls_most` (the bytes() of a run after its set-up, estimated ahead: `knitflow plan`):
  /// bytes a fluid particle (its row and count, with a skin the position listed) and a boundary
  /// particle (with a skin, its wall row: `walls`). The local bound's boxes of displacements
  /// come later, when it first runs, over the cells the fluid fills (none at the set-up).
  static SphListsFootprint footprint(std::uint32_t most, std::uint32_t walls_most, bool skin,
                                     bool walls) {
    const std::uint32_t width = NeighbourList<T>::settled_capacity(most);
    SphListsFootprint f;
    f.per_fluid = sizeof(std::uint32_t) * (width + 1.0) + (skin ? sizeof(Vec3<T>) : 0);
    if (skin && walls)
      f.per_boundary =
          sizeof(std::uint32_t) * (NeighbourList<T>::settled_capacity(walls_most) + 1.0);
    return f;
  }
  /// The last device reading: max |d| and the bound on |d_i - d_j| it gave (the smallest of
  /// the three), and the local bound alone (for tests; infinity when the global bounds decided
  /// without it).
  T last_largest() const { return last_largest_; }
  T last_pair_bound() const { return last_pair_; }
  T last_local() const { return last_local_; }

  /// One cell's box of displacements (empty: lo > hi). A NaN never widens it (the global
  /// reading catches NaNs).
  struct Box {
    Vec3<T> lo, hi;
    KF_HD KF_INLINE static Box empty() {
      const T big = std::numeric_limits<T>::max();
      return {{big, big, big}, {-big, -big, -big}};
    }
    KF_HD KF_INLINE void add(const Box& b) {
      lo = {b.lo.x < lo.x ? b.lo.x : lo.x, b.lo.y < lo.y ? b.lo.y : lo.y,
            b.lo.z < lo.z ? b.lo.z : lo.z};
      hi = {b.hi.x > hi.x ? b.hi.x : hi.x, b.hi.y > hi.y ? b.hi.y : hi.y,
            b.hi.z > hi.z ? b.hi.z : hi.z};
    }
    KF_HD KF_INLINE void add(const Vec3<T>& d) { add(Box{d, d}); }
  };

private:
  void build_walls(const exec::Exec& ex, const BoundaryNeighbours<T>& b, const CellView<T>& cells,
                   T r2, const std::uint8_t* fluid_near);

  T skin_;
  NeighbourList<T> lists_;
  NeighbourList<T> walls_;
  bool walls_listed_ = false;
  std::uint32_t walls_width_ = 0; // the walls' rows' (0 before the first build)
  std::uint64_t walls_builds_ = 0;
  exec::DeviceBuffer<Vec3<T>> x0_;
  // Since the build: [0] max |d|^2, [1-6] max(d_c, 0) and max(-d_c, 0) for c = x, y, z; [7-12]
  // the box of the cells the build filled, max c_a and max (n_a - 1 - c_a) for a = x, y, z (the
  // local pass runs over it); [13] the local bound squared.
  exec::DeviceBuffer<T> moved_;
  exec::PendingRead<T> read_; // moved_ on the host
  // What the last build listed, for settle() to build again when a row overflowed.
  struct Built {
    FluidView<T> f;
    CellView<T> cells;
    BoundaryNeighbours<T> b;
    T r2;
  } built_{};
  CellView<T> cells_; // the grid of the build (its tables stay until the next sort)
  exec::DeviceBuffer<Box> box_, spread_;
  T bound_ = std::numeric_limits<T>::infinity(); // host bound on max |d| since the build
  T pair_ = std::numeric_limits<T>::infinity();  // host bound on the pairs' |d_i - d_j|
  T last_largest_ = 0, last_pair_ = 0, last_local_ = 0;
  Ends ends_;
  std::function<void(T*, int)> combine_; // the readings' largest over the job (N ranks)
};

} // namespace kf
