#pragma once
// How far a point set has moved since a grid or list was built for it, kept on the device so
// that kernels can tell a stale structure without the host waiting. A structure built for
// positions x0 with a skin s (its reach plus s is what it covers) finds every pair as long as no
// point is farther than s from x0; `observe` records the largest displacement seen since `reset`
// into one device word, a kernel reads it and takes an exact fallback past the skin, and the
// host reads it (`moved`) only where it decides whether to rebuild, once per fluid step.
#include "kernels/exec/Algorithms.hpp"
#include "kernels/grid/NeighbourGrid.hpp"

#include <functional>
#include <limits>
#include <string>
#include <vector>

namespace kf {

/// Gathers positions and velocities through a permutation (out[k] = in[perm[k]]) and returns the
/// squared displacement of the point gathered (NaN read as the largest value): one pass for a
/// structure's sorted copies and its watch.
template <typename T>
struct GatherDisplaced {
  const std::uint32_t* perm;
  const Vec3<T>* x;
  const Vec3<T>* v;
  const Vec3<T>* x0;
  Vec3<T>* x_out;
  Vec3<T>* v_out;
  KF_HD KF_INLINE T operator()(std::size_t k) const {
    const std::uint32_t i = perm[k];
    const Vec3<T> xi = x[i];
    x_out[k] = xi;
    v_out[k] = v[i];
    const T d2 = norm2(xi - x0[i]);
    return d2 == d2 ? d2 : std::numeric_limits<T>::max();
  }
};

template <typename T>
class SkinWatch {
public:
  SkinWatch(exec::Backend b, T skin, const char* name)
      : skin_(skin), x0_(b, 0, name), moved2_(b, 0, name), label_(name) {
    moved2_.assign(std::vector<T>{std::numeric_limits<T>::max()}); // stale until reset
  }

  /// The positions now become the reference; the recorded motion is zero.
  void reset(const exec::Exec& ex, const exec::DeviceBuffer<Vec3<T>>& x) {
    x0_.resize(x.size());
    x0_.copy_from(x, x.size());
    exec::fill(ex, moved2_, T(0), label_);
    bound_ = T(0);
  }
  /// Once per step, before it: calls rebuild() (which must reset() the watch) when the structure
  /// may not last the step, then adds the step's expected motion (an estimate, from speeds and
  /// accelerations) to the host's bound. With twice the motion inside the skin, "may not last"
  /// is may_exceed(skin - 2 motion), read on the host only when the bound could have used the
  /// skin up; otherwise a sort might not last the step anyway, and the rule is the exact reading
  /// (moved past the skin). `force` (a count changed) rebuilds without asking.
  template <typename Rebuild>
  void before_step(const exec::Exec& ex, const exec::DeviceBuffer<Vec3<T>>& x, T motion, bool force,
                   Rebuild&& rebuild) {
    bool stale = force;
    if (!stale && T(2) * motion <= skin_) {
      stale = may_exceed(ex, x, skin_ - T(2) * motion);
    } else if (!stale) {
      bound_ = moved(ex, x);
      stale = !(bound_ <= skin_);
    }
    if (stale)
      rebuild();
    bound_ += motion;
  }
  /// Device side, nothing waits: the recorded squared motion takes the largest displacement now.
  void observe(const exec::Exec& ex, const exec::DeviceBuffer<Vec3<T>>& x) {
    if (x0_.size() != x.size()) { // never reset for this count: stale
      exec::fill(ex, moved2_, std::numeric_limits<T>::max(), label_);
      return;
    }
    exec::max_into(ex, x.size(), SquaredDisplacement<T>{x.data(), x0_.data()}, moved2_.data(),
                   label_);
  }
  /// observe() and, in the same pass, x_out[k] = x[perm[k]], v_out[k] = v[perm[k]] for k < n.
  void observe_gather(const exec::Exec& ex, const exec::DeviceBuffer<Vec3<T>>& x,
                      const exec::DeviceBuffer<Vec3<T>>& v,
                      const exec::DeviceBuffer<std::uint32_t>& perm,
                      exec::DeviceBuffer<Vec3<T>>& x_out, exec::DeviceBuffer<Vec3<T>>& v_out) {
    exec::max_into(ex, perm.size(), gathering(x, v, perm, x_out, v_out), moved2_.data(), label_);
  }
  /// observe_gather's per-slot functor (for a pass that serves two watches: observe_gather
  /// below); checks the sizes.
  GatherDisplaced<T> gathering(const exec::DeviceBuffer<Vec3<T>>& x,
                               const exec::DeviceBuffer<Vec3<T>>& v,
                               const exec::DeviceBuffer<std::uint32_t>& perm,
                               exec::DeviceBuffer<Vec3<T>>& x_out,
                               exec::DeviceBuffer<Vec3<T>>& v_out) const {
    const std::size_t n = perm.size();
    if (x0_.size() != x.size() || n != x.size() || x_out.size() != n || v_out.size() != n)
      throw Error(std::string(label_) + ": observe_gather of " + std::to_string(x.size()) +
                  " points through a permutation of " + std::to_string(n) + " into " +
                  std::to_string(x_out.size()) + " / " + std::to_string(v_out.size()) +
                  " slots, watching " + std::to_string(x0_.size()));
    return {perm.data(), x.data(), v.data(), x0_.data(), x_out.data(), v_out.data()};
  }
  /// The device word of the recorded squared motion (a pass that observes writes it).
  T* record() { return moved2_.data(); }
  /// observe(), then the farthest any point has been from its reference at an observation since
  /// reset, read on the host (waits for the device). A NaN position reads as infinitely far.
  T moved(const exec::Exec& ex, const exec::DeviceBuffer<Vec3<T>>& x) {
    observe(ex, x);
    T m2 = moved2_.host_value(0);
    if (job_max_)
      m2 = job_max_(m2 == m2 ? m2 : std::numeric_limits<T>::max());
    return m2 >= T(0) && m2 < std::numeric_limits<T>::max() ? ksqrt(m2)
                                                            : std::numeric_limits<T>::infinity();
  }

  /// What the watch carries from step to step: the reference positions, the device's record
  /// and the host's bound. A restart restores it, so that its structure is sorted again when the
  /// uninterrupted run sorted it (a sort at another step sums the same pairs in another order).
  struct State {
    std::vector<Vec3<T>> x0;
    T moved2 = std::numeric_limits<T>::max();
    T bound = std::numeric_limits<T>::infinity();
  };
  State state() const { return {x0_.to_host(), moved2_.host_value(0), bound_}; }
  /// After the owner sorted its structure for s.x0 (which reset() the watch to them).
  void restore(const State& s) {
    moved2_.assign(std::vector<T>{s.moved2});
    bound_ = s.bound;
  }

  /// On N ranks: the host's readings become the largest over the job (collective), so every
  /// rank decides to rebuild when the one-rank run does (its watch sees all points).
  void set_job_max(std::function<T(T)> job_max) { job_max_ = std::move(job_max); }

  T skin() const { return skin_; }
  T skin2() const { return skin_ * skin_; }
  /// For kernels: the structure is stale when *moved2() > skin2().
  const T* moved2() const { return moved2_.data(); }
  /// The host's bound on the motion since reset (see may_exceed).
  T bound() const { return bound_; }
  std::size_t bytes() const { return x0_.capacity_bytes() + moved2_.capacity_bytes(); }

private:
  /// Whether a point may be farther than `limit` from its reference. Answered on the host when
  /// the bound it keeps (the last reading plus the motion expected since) is within the limit;
  /// else the device is read (waits) and the bound becomes the reading. An expectation that
  /// proves too small costs no correctness: kernels still see the device's record.
  bool may_exceed(const exec::Exec& ex, const exec::DeviceBuffer<Vec3<T>>& x, T limit) {
    if (x0_.size() == x.size() && bound_ <= limit)
      return false;
    bound_ = moved(ex, x);
    return !(bound_ <= limit);
  }

  T skin_;
  exec::DeviceBuffer<Vec3<T>> x0_;
  exec::DeviceBuffer<T> moved2_;
  const char* label_;
  T bound_ = std::numeric_limits<T>::infinity();
  std::function<T(T)> job_max_;
};

/// A structure's sorted copies of a point set (x[k] = the set's x[perm[k]], v likewise) and the
/// watch of its motion: what observe_gather fills. No watch: nothing to fill.
template <typename T>
struct WatchedCopies {
  SkinWatch<T>* watch = nullptr;
  const exec::DeviceBuffer<std::uint32_t>* perm = nullptr;
  exec::DeviceBuffer<Vec3<T>>* x = nullptr;
  exec::DeviceBuffer<Vec3<T>>* v = nullptr;
};

/// Both structures' gathers over the same points, and their watches', in one pass.
template <typename T>
struct GatherDisplacedTwice {
  GatherDisplaced<T> a, b;
  KF_HD KF_INLINE exec::Maxima<T, 2> operator()(std::size_t k) const { return {{a(k), b(k)}}; }
};

/// observe_gather for the copies of two structures over the set (x, v): one pass where both
/// are watched (the knit's self-contact and its coupling each keep copies in their grid's
/// order; their gathers were a launch each in every force evaluation), else the one's.
template <typename T>
void observe_gather(const exec::Exec& ex, const exec::DeviceBuffer<Vec3<T>>& x,
                    const exec::DeviceBuffer<Vec3<T>>& v, const WatchedCopies<T>& a,
                    const WatchedCopies<T>& b, const char* label) {
  if (!a.watch || !b.watch) {
    for (const WatchedCopies<T>* c : {&a, &b})
      if (c->watch)
        c->watch->observe_gather(ex, x, v, *c->perm, *c->x, *c->v);
    return;
  }
  const GatherDisplacedTwice<T> both{a.watch->gathering(x, v, *a.perm, *a.x, *a.v),
                                     b.watch->gathering(x, v, *b.perm, *b.x, *b.v)};
  exec::max_into_each<T, 2>(ex, x.size(), both,
                            exec::MaxTargets<T, 2>{{a.watch->record(), b.watch->record()}}, label);
}

} // namespace kf
