#pragma once
// Contact of one point with the rigid solids, as a host-device functor: used alone
// (enforce_rigid_shapes) and fused after a drift (kick_drift_contact).
#include "kernels/boundary/RigidShape.hpp"
#include "kernels/exec/Algorithms.hpp"
#include "kernels/integrate/Verlet.hpp"

namespace kf {

/// Where the energy a moving solid's contact gives a point goes (the watchdog's budget,
/// domain/Watchdog): each correction by a solid that moves adds its change of the point's kinetic
/// and gravitational energy, 1/2 m (|v'|^2 - |v|^2) - m g . (x' - x), to *sum as a 64-bit
/// fixed-point integer in units of `unit` joules (two's complement for a loss): integer adds are
/// exact, so the total does not depend on the order the points add in. A solid at rest is not
/// measured (it does no work; the correction only takes energy, or lifts a point by less than
/// the margin). sum null: nothing measured.
template <typename T>
struct ContactWork {
  const T* m = nullptr;
  Vec3<T> g{};
  double unit = 1.0;
  std::uint64_t* sum = nullptr;

  KF_HD KF_INLINE void add(std::size_t i, const Vec3<T>& x0, const Vec3<T>& v0, const Vec3<T>& x1,
                           const Vec3<T>& v1) const {
    const double mi = double(m[i]);
    const double de =
        0.5 * mi * (double(norm2(v1)) - double(norm2(v0))) - mi * double(dot(g, x1 - x0));
    const double q = de / unit;
    exec::atomic_add(sum, static_cast<std::uint64_t>(static_cast<std::int64_t>(
                              q < 0 ? q - 0.5 : q + 0.5))); // rounded to the nearest unit
  }
};

/// Puts one point back outside every solid; returns 1 when it was corrected.
template <typename T>
struct RigidContact {
  Vec3<T>* x;
  Vec3<T>* v;
  const RigidShape<T>* shapes;
  std::size_t n_shapes;
  T margin, friction;
  const std::uint32_t* fixed;
  ContactWork<T> work{};

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
      const Vec3<T> vs = shapes[s].velocity;
      const bool measured = work.sum && (vs.x != T(0) || vs.y != T(0) || vs.z != T(0));
      const Vec3<T> x0 = x[i], v0 = v[i];
      x[i] += nrm * (margin - d);
      const Vec3<T> rel = v[i] - vs;
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
      if (measured)
        work.add(i, x0, v0, x[i], v[i]);
      hits = 1;
    }
    return hits;
  }
};

} // namespace kf
