#pragma once
// The DEM pair force of paper Eq. 7 and 8 as corrected in DESIGN §10, shared by knit
// self-collision and knit-fluid contact: one formula, both backends.
#include "core/Math.hpp"
#include "core/Vec3.hpp"

namespace kf {

/// DEM material of a pair: stiffness k [N/m], normal damping ratio zeta (of critical for the
/// pair's reduced mass) and Coulomb coefficient mu.
template <typename T>
struct DemMaterial {
  T k = T(0);
  T zeta = T(0);
  T friction = T(0);
};

/// Force on i from j (d = x_i - x_j, dv = v_i - v_j), zero unless |d| < reach:
/// normal  F_n = max(0, k u - c v_n) r^ with u = reach - |d| > 0 the overlap (Eq. 7, repulsive),
///         c = 2 zeta sqrt(k m_red);
/// tangent F_t = -min(mu F_n, gamma |v_t|) v_t^ (Eq. 8, opposing the sliding, and regularised:
///         below the Coulomb cap it is viscous with gamma = 2 sqrt(k m_red), so it fades to zero
///         with v_t instead of chattering).
/// Antisymmetric: swapping i and j negates d, dv and f bit for bit.
template <typename T>
KF_HD KF_INLINE bool dem_pair_force(const Vec3<T>& d, const Vec3<T>& dv, T mi, T mj, T reach,
                                    const DemMaterial<T>& mat, Vec3<T>& f) {
  const T r2 = norm2(d);
  if (r2 >= reach * reach || r2 <= T(0))
    return false;
  const T r = ksqrt(r2);
  const Vec3<T> n = d * (T(1) / r);
  const T overlap = reach - r;
  const T mred = mi * mj / (mi + mj);
  const T crit = T(2) * ksqrt(mat.k * mred);
  const T vn = dot(dv, n);
  T fn = mat.k * overlap - mat.zeta * crit * vn;
  if (fn < T(0))
    fn = T(0); // damping may slow a separation but never pulls the points together
  f = n * fn;
  const Vec3<T> vt = dv - n * vn;
  const T vt_len = norm(vt);
  if (vt_len > T(0)) {
    const T viscous = crit * vt_len, coulomb = mat.friction * fn;
    f -= vt * ((viscous < coulomb ? viscous : coulomb) / vt_len);
  }
  return true;
}

} // namespace kf
