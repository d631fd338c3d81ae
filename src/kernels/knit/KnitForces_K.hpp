#pragma once
// The knit's forces on its points in one pass: springs and volume cells with gravity, and, when
// on, self-contact and a term from outside (the fluid's coupling). Each term is an evaluator's
// force(i, lanes); a point's acceleration is composed in registers and written once. A pass a
// term wrote a and the next read it again, and at the pour's 50k points each launch cost more
// than its work (docs/PERFORMANCE.md, P10 stage 5).
#include "kernels/exec/Algorithms.hpp"
#include "kernels/knit/KnitEvaluators_K.hpp"
#include "kernels/knit/KnitLanes.hpp"
#include "kernels/knit/SelfContact_K.hpp"

#include <cstddef>
#include <type_traits>

// g++ (the CPU build) inlines the terms' force() calls into the one pass as into their own.
#if defined(__GNUC__) && !defined(__CUDACC__) && !defined(__clang__)
#define KF_FLATTEN __attribute__((flatten))
#else
#define KF_FLATTEN
#endif

namespace kf {

/// A term the pass does not have.
struct NoKnitTerm {};

/// a_i = springs / m_i + g, then + self / m_i, then + extra / m_i for a free point (the
/// arithmetic, term by term, of the separate passes it replaces: their sums to the bit); a = 0
/// on a handle's points, and where `held` is set, the forces on them there (springs + self +
/// extra's held_force: what the handle holds its point against; HandleWorkEvaluator). Self and
/// Extra: evaluators with force(i, lanes) (Extra also held_force(i, lanes)), or NoKnitTerm.
template <typename T, typename Self, typename Extra>
struct KnitPointForces {
  SpringForceEvaluator<T> springs;
  Self self;
  Extra extra;
  Vec3<T>* held = nullptr;

  KF_HD KF_FLATTEN void operator()(std::size_t i, exec::Lanes g = {}) const {
    const KnitView<T>& p = springs.p;
    if (p.handle[i] != kFreePoint) {
      if (held) { // the group's lanes alike: they read point i's words only
        Vec3<T> f = springs.force(i, g);
        if constexpr (!std::is_same_v<Self, NoKnitTerm>)
          f += self.force(i, g);
        if constexpr (!std::is_same_v<Extra, NoKnitTerm>)
          f += extra.held_force(i, g);
        if (g.lane == 0)
          held[i] = f;
      }
      if (g.lane == 0)
        p.a[i] = {T(0), T(0), T(0)};
      return;
    }
    const T inv_m = T(1) / p.m[i];
    Vec3<T> a = springs.force(i, g) * inv_m + springs.gravity;
    if constexpr (!std::is_same_v<Self, NoKnitTerm>)
      a += self.force(i, g) * inv_m;
    if constexpr (!std::is_same_v<Extra, NoKnitTerm>)
      a += extra.force(i, g) * inv_m;
    if (g.lane == 0)
      p.a[i] = a;
  }
};

/// The knit's own terms of a force pass: springs, volume cells and gravity; self-contact when on.
template <typename T>
struct KnitForceTerms {
  SpringForceEvaluator<T> springs;
  SelfContactEvaluator<T> self{};
  bool with_self = false;
  Vec3<T>* held = nullptr; // where set, the forces on the handles' points (KnitPointForces)
};

/// a = (the knit's own forces + extra's) / m + g on points [0, n), in one pass of kKnitLanes lanes
/// a point (the lanes of springs.force, self.force and extra.force alike). Instantiate it in a
/// kernels translation unit (compiled by nvcc when CUDA is on), as every launch.
template <typename T, typename Extra>
void knit_forces_with(const exec::Exec& ex, std::size_t n, const KnitForceTerms<T>& own,
                      const Extra& extra, const char* label) {
  if (own.with_self)
    exec::for_each_lanes<kKnitLanes>(
        ex, n,
        KnitPointForces<T, SelfContactEvaluator<T>, Extra>{own.springs, own.self, extra, own.held},
        label);
  else
    exec::for_each_lanes<kKnitLanes>(
        ex, n, KnitPointForces<T, NoKnitTerm, Extra>{own.springs, {}, extra, own.held}, label);
}

} // namespace kf
