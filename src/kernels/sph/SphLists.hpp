#pragma once
// The fluid's neighbour lists (solver.neighbour_list): for each fluid particle, its fluid and
// then its boundary neighbours within the support plus a skin s. With a skin the lists, the
// fluid's order and its grid are kept over steps (a Verlet list) while both hold:
//  - every particle is within s of where it was listed: a boundary particle (which stays put)
//    within h now was within h + s then, and a walk of the grid, whose cells reach h + s, still
//    finds every particle within h of a point;
//  - two fluid particles closed in by at most s: |d_i - d_j| <= |d_i - u| + |d_j - u| for any
//    common vector u, so either every |d_i| <= s / 2, or the box of all displacements d_i
//    (origin included) has a diagonal within s (u its centre); the origin in the box makes the
//    first condition follow. The box lets a fluid that moves together (a falling column, a
//    surge) keep its lists longer: the dam break test (skin 0.15) sorts 11 times in 300 steps,
//    not 19.
#include "kernels/grid/NeighbourList.hpp"
#include "kernels/sph/Sph.hpp"

#include <limits>

namespace kf {

template <typename T>
class SphLists {
public:
  /// skin 0: lists of the support only, to be built again every step.
  SphLists(exec::Backend b, T skin);

  /// Lists every particle of f (sorted as `cells` describes) against f and the boundary b,
  /// within the support h plus the skin, and takes the positions now as the reference.
  void build(const exec::Exec& ex, FluidSet<T>& f, const CellView<T>& cells,
             const BoundaryNeighbours<T>& b, T h);
  /// After the fluid moved by at most `motion` since the last call (a true bound; infinity:
  /// unknown), whether the lists may have missed a pair and must be built again. Reads the
  /// device only when the host's bound has used half the skin up. `force`: true, unasked.
  bool stale_after(const exec::Exec& ex, const FluidSet<T>& f, T motion, bool force);
  /// The fluid's arrays were replaced (a restart): the next stale_after says so.
  void forget() { x0_.resize(0); }

  ListView<T> view() const { return lists_.view(); }
  T skin() const { return skin_; }
  std::uint32_t capacity() const { return lists_.capacity(); }
  std::size_t bytes() const {
    return lists_.bytes() + x0_.capacity_bytes() + moved_.capacity_bytes();
  }

private:
  T skin_;
  NeighbourList<T> lists_;
  exec::DeviceBuffer<Vec3<T>> x0_;
  // Since the build: max |d|^2, then max(d_c, 0) and max(-d_c, 0) for c = x, y, z.
  exec::DeviceBuffer<T> moved_;
  T bound_ = std::numeric_limits<T>::infinity(); // host bound on max |d| since the build
};

} // namespace kf
