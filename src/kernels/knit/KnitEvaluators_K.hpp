#pragma once
// Knit evaluators as host-device functors: each point gathers the forces of its own springs.
#include "core/Math.hpp"
#include "kernels/knit/LocalRows_K.hpp"
#include "kernels/knit/SpringTopology.hpp"
#include "kernels/knit/VolumeTopology.hpp"
#include "kernels/particles/KnitSet.hpp"

namespace kf {

/// Force of one damped spring on point i, with j at the other end:
/// k (|d| - L) d^ + c ((v_j - v_i) . d^) d^, d = x_j - x_i. Equal and opposite for j.
template <typename T>
KF_HD KF_INLINE Vec3<T> spring_force(const Vec3<T>& d, const Vec3<T>& dv, T rest, T k, T c) {
  const T len = norm(d);
  if (len <= T(0))
    return {T(0), T(0), T(0)};
  const Vec3<T> u = d * (T(1) / len);
  return u * (k * (len - rest) + c * dot(dv, u));
}

/// Calls f(V - V0, k, gradient of V with respect to point i) for every volume cell of point i
/// (with lanes: for every stride-th from `lane` on).
template <typename T, typename F>
KF_HD KF_INLINE void for_each_volume_cell(const VolumeView<T>& vol, const Vec3<T>* x, std::size_t i,
                                          F&& f, std::uint32_t lane = 0, std::uint32_t stride = 1) {
  if (vol.empty())
    return;
  const std::uint32_t cells = vol.count[i];
  for (std::uint32_t e = lane; e < cells; e += stride) {
    const std::uint32_t c = vol.cell[vol.rows.at(e, i)];
    const std::uint32_t* q = vol.point + 4 * std::size_t(c);
    const Vec3<T> xp = x[q[0]], xo = x[q[1]], xa = x[q[2]], xb = x[q[3]];
    const int role = q[0] == i ? 0 : q[1] == i ? 1 : q[2] == i ? 2 : 3;
    f(tet_volume(xp, xo, xa, xb) - vol.rest[c], vol.k[c],
      tet_volume_gradient(xp, xo, xa, xb, role));
  }
}

/// The force of point i's springs and volume cells on it (this lane's share: every stride-th
/// from `lane` on; the caller sums the lanes).
template <typename T>
KF_HD KF_INLINE Vec3<T> elastic_force(const KnitView<T>& p, const SpringView<T>& s,
                                      const VolumeView<T>& vol, std::size_t i,
                                      std::uint32_t lane = 0, std::uint32_t stride = 1) {
  const Vec3<T> xi = p.x[i], vi = p.v[i];
  Vec3<T> f{T(0), T(0), T(0)};
  s.for_each_spring(
      i,
      [&](const SpringEntry<T>& e) {
        f += spring_force(p.x[e.other] - xi, p.v[e.other] - vi, e.rest, e.k, e.c);
      },
      lane, stride);
  for_each_volume_cell(
      vol, p.x, i, [&](T dv, T k, const Vec3<T>& grad) { f -= grad * (k * dv); }, lane, stride);
  return f;
}

/// a_i = (sum of spring and volume forces) / m_i + g for every free point; points on a handle get
/// a = 0 (their motion is prescribed).
template <typename T>
struct SpringForceEvaluator {
  KnitView<T> p;
  SpringView<T> s;
  VolumeView<T> vol;
  Vec3<T> gravity;

  /// The elastic force on free point i, summed over the group's lanes (KnitPointForces).
  KF_HD KF_INLINE Vec3<T> force(std::size_t i, exec::Lanes g) const {
    return g.sum(elastic_force(p, s, vol, i, g.lane, g.size));
  }

  KF_HD void operator()(std::size_t i, exec::Lanes g = {}) const {
    if (p.handle[i] != kFreePoint) {
      if (g.lane == 0)
        p.a[i] = {T(0), T(0), T(0)};
      return;
    }
    const Vec3<T> f = force(i, g);
    if (g.lane == 0)
      p.a[i] = f * (T(1) / p.m[i]) + gravity;
  }
};

/// The work a moving handle's constraint does on point i over a time h: it holds the point to
/// the handle's velocity u against every other force on it, f (its springs and volume cells,
/// the self-contact, the fluid's push: KnitPointForces' `held`) and its weight, with the force
/// -(f + m g), whose power is that force dotted with u. 0 for free and still points. A handle's
/// point pushes the fluid and the other points like any point (they feel it; it does not move
/// for them): that work enters the fluid's and the knit's energy, so it is counted.
template <typename T>
struct HandleWorkEvaluator {
  KnitView<T> p;
  const Vec3<T>* held;
  Vec3<T> gravity;
  const Vec3<T>* handle_v;
  T h;

  KF_HD double operator()(std::size_t i) const {
    if (p.handle[i] == kFreePoint)
      return 0.0;
    const Vec3<T> u = handle_v[p.handle[i]];
    if (u.x == T(0) && u.y == T(0) && u.z == T(0))
      return 0.0;
    const Vec3<T> f = held[i] + gravity * p.m[i];
    return -double(h) * double(dot(f, u));
  }
};

/// Point i's share of the elastic energy: half of each of its springs' 1/2 k (|d| - L)^2 and a
/// quarter of each of its volume cells' 1/2 k (V - V0)^2.
template <typename T>
struct SpringEnergyEvaluator {
  KnitView<T> p;
  SpringView<T> s;
  VolumeView<T> vol;

  KF_HD double operator()(std::size_t i) const {
    double e = 0;
    s.for_each_spring(i, [&](const SpringEntry<T>& sp) {
      const double stretch = double(norm(p.x[sp.other] - p.x[i])) - double(sp.rest);
      e += 0.25 * double(sp.k) * stretch * stretch;
    });
    for_each_volume_cell(vol, p.x, i, [&](T dv, T k, const Vec3<T>&) {
      e += 0.125 * double(k) * double(dv) * double(dv);
    });
    return e;
  }
};

/// Point i's explicit-integration limits: sqrt(m / sum k) (spring) and m / sum c (damping); a
/// volume cell counts as a spring of stiffness k |dV/dx_i|^2.
template <typename T>
struct SpringLimits {
  T spring = T(1e30), damping = T(1e30);
};

/// How far an owned point's partners lie (the other ends of its springs, the other corners of
/// its volume cells; squared) and whether one of them is absent (kAbsentPoint in the localized
/// rows): a rank's check that its ghosts hold every partner (KnitHalo).
template <typename T>
struct PartnerReach {
  T d2 = T(0);
  std::uint32_t missing = 0;
};

struct PartnerReachMaxOp {
  template <typename T>
  KF_HD KF_INLINE PartnerReach<T> operator()(const PartnerReach<T>& a,
                                             const PartnerReach<T>& b) const {
    return {a.d2 < b.d2 ? b.d2 : a.d2, a.missing > b.missing ? a.missing : b.missing};
  }
};

template <typename T>
struct PartnerReachEvaluator {
  const Vec3<T>* x;
  SpringView<T> s;
  VolumeView<T> vol;

  KF_HD PartnerReach<T> operator()(std::size_t i) const {
    PartnerReach<T> r;
    const auto meet = [&](std::uint32_t q) {
      if (q == kAbsentPoint) {
        r.missing = 1;
        return;
      }
      const T d2 = norm2(x[q] - x[i]);
      r.d2 = d2 > r.d2 ? d2 : r.d2; // (a NaN is left out, as the host's max did)
    };
    s.for_each_spring(i, [&](const SpringEntry<T>& e) { meet(e.other); });
    if (vol.empty())
      return r;
    for (std::uint32_t e = 0; e < vol.count[i]; ++e) {
      const std::uint32_t c = vol.cell[vol.rows.at(e, i)];
      for (int k = 0; k < 4; ++k)
        if (vol.point[4 * std::size_t(c) + k] != i)
          meet(vol.point[4 * std::size_t(c) + k]);
    }
    return r;
  }
};

template <typename T>
struct SpringLimitEvaluator {
  KnitView<T> p;
  SpringView<T> s;
  VolumeView<T> vol;

  KF_HD SpringLimits<T> operator()(std::size_t i) const {
    T ks = T(0), cs = T(0);
    s.for_each_spring(i, [&](const SpringEntry<T>& e) {
      ks += e.k;
      cs += e.c;
    });
    for_each_volume_cell(vol, p.x, i, [&](T, T k, const Vec3<T>& grad) { ks += k * norm2(grad); });
    SpringLimits<T> l;
    if (p.handle[i] != kFreePoint)
      return l; // prescribed points do not integrate springs
    if (ks > T(0))
      l.spring = ksqrt(p.m[i] / ks);
    if (cs > T(0))
      l.damping = p.m[i] / cs;
    return l;
  }
};

} // namespace kf
