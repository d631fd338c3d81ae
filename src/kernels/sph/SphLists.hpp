#pragma once
// The fluid's neighbour lists (solver.neighbour_list): for each fluid particle, its fluid and
// then its boundary neighbours within the support plus a skin. With a skin the lists, the fluid's
// order and its grid are kept over steps until some particle may have moved half the skin
// (a Verlet list): every pair within the support then still is in the lists, and a walk of the
// grid, whose cells reach the support plus the skin, still finds every particle within the support.
#include "kernels/grid/NeighbourList.hpp"
#include "kernels/grid/SkinWatch.hpp"
#include "kernels/sph/Sph.hpp"

namespace kf {

template <typename T>
class SphLists {
public:
  /// skin 0: lists of the support only, to be built again every step.
  SphLists(exec::Backend b, T skin);

  /// Lists every particle of f (sorted as `cells` describes) against f and the boundary b,
  /// within the support h plus the skin, and takes the positions now as the watch's reference.
  void build(const exec::Exec& ex, const FluidSet<T>& f, const CellView<T>& cells,
             const BoundaryNeighbours<T>& b, T h);
  /// After the fluid moved by at most `motion` since the last call (a true bound; infinity:
  /// unknown), whether the lists may have missed a pair and must be built again. Reads the
  /// device only when the host's bound has used the half skin up. `force`: true, unasked.
  bool stale_after(const exec::Exec& ex, const FluidSet<T>& f, T motion, bool force);

  ListView<T> view() const { return lists_.view(); }
  T skin() const { return skin_; }
  std::uint32_t capacity() const { return lists_.capacity(); }
  std::size_t bytes() const { return lists_.bytes() + watch_.bytes(); }

private:
  T skin_;
  NeighbourList<T> lists_;
  SkinWatch<T> watch_; // skin / 2: two particles closing in on each other use the whole skin
};

} // namespace kf
