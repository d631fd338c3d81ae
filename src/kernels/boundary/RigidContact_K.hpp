#pragma once
// Contact of one point with the rigid solids, as a host-device functor: used alone
// (enforce_rigid_shapes) and fused after a drift (kick_drift_contact).
#include "kernels/boundary/RigidShape.hpp"
#include "kernels/integrate/Verlet.hpp"

namespace kf {

/// Puts one point back outside every solid; returns 1 when it was corrected.
template <typename T>
struct RigidContact {
  Vec3<T>* x;
  Vec3<T>* v;
  const RigidShape<T>* shapes;
  std::size_t n_shapes;
  T margin, friction;
  const std::uint32_t* fixed;

  KF_HD std::uint64_t operator()(std::size_t i) const {
    if (fixed && fixed[i] != kNoHandle)
      return 0;
    std::uint64_t hits = 0;
    for (std::size_t s = 0; s < n_shapes; ++s) {
      if (shapes[s].clear_by(x[i], margin))
        continue;
      Vec3<T> nrm;
      const T d = shapes[s].distance(x[i], nrm);
      if (d >= margin)
        continue;
      x[i] += nrm * (margin - d);
      const Vec3<T> rel = v[i] - shapes[s].velocity;
      const T vn = dot(rel, nrm);
      if (vn < T(0)) {
        v[i] -= nrm * vn;
        if (friction > T(0)) { // Coulomb: tangential speed drops by friction |vn|, not past 0
          const Vec3<T> vt = rel - nrm * vn;
          const T vt_len = norm(vt);
          const T lose = vt_len > T(0) ? kmin(T(1), friction * (-vn) / vt_len) : T(0);
          v[i] -= vt * lose;
        }
      }
      hits = 1;
    }
    return hits;
  }
};

} // namespace kf
