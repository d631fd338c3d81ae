#pragma once
// The tunnelling guard's geometry (P8 stage 5; docs/ARCHITECTURE.md "Tunnelling guard"): does a
// fluid particle's step cross a face of the knit's sheet, and where does it go back to. Written
// once for both backends.
#include "core/HostDevice.hpp"
#include "core/Math.hpp"
#include "core/Vec3.hpp"
#include "kernels/exec/Algorithms.hpp"
#include "kernels/grid/GridGeometry.hpp"
#include "kernels/integrate/Verlet.hpp"

#include <cstdint>
#include <limits>

namespace kf {

/// Where the segment p0 -> p1 crosses the triangle (a, b, c): s in [0, 1] along the segment, and
/// the triangle's unit normal n (the side p0 lies on: n . (p0 - a) >= 0). A segment in the
/// triangle's plane, or one touching only an edge's extension, does not cross. Moeller-Trumbore
/// with the segment's own length as the ray's, the barycentric bounds closed (an edge shared by
/// two faces crosses at least one).
template <typename T>
struct SheetCrossing {
  bool crosses = false;
  T s = T(0);
  Vec3<T> n{};
};

template <typename T>
KF_HD KF_INLINE SheetCrossing<T> segment_crosses_triangle(const Vec3<T>& p0, const Vec3<T>& p1,
                                                          const Vec3<T>& a, const Vec3<T>& b,
                                                          const Vec3<T>& c) {
  SheetCrossing<T> out;
  const Vec3<T> d = p1 - p0, e1 = b - a, e2 = c - a;
  const Vec3<T> q = cross(d, e2);
  const T det = dot(e1, q);
  // Parallel within 1e-5 rad (or degenerate): no crossing. Relative, so independent of units.
  const T scale = norm2(d) * norm2(e1) * norm2(e2);
  if (!(det * det > T(1e-10) * scale))
    return out;
  const T inv = T(1) / det;
  const Vec3<T> r = p0 - a;
  const T u = dot(r, q) * inv;
  if (u < T(0) || u > T(1))
    return out;
  const Vec3<T> w = cross(r, e1);
  const T v = dot(d, w) * inv;
  if (v < T(0) || u + v > T(1))
    return out;
  const T s = dot(e2, w) * inv;
  if (s < T(0) || s > T(1))
    return out;
  Vec3<T> n = cross(e1, e2);
  n = n * (T(1) / ksqrt(norm2(n)));
  if (dot(n, r) < T(0))
    n = n * T(-1);
  out.crosses = true;
  out.s = s;
  out.n = n;
  return out;
}

/// When a point moving from p0 to p1 meets a triangle whose corners move from (a0, b0, c0) to
/// (a1, b1, c1), all linearly over t in [0, 1] (continuous collision detection): the first t
/// where the point lies in the triangle's plane and inside it (barycentric weights wb, wc of b
/// and c, closed bounds widened by `slack_bary` so that an edge shared by two faces is met by
/// one of them in floating point), and the side it came from (+1: the side cross(b - a, c - a)
/// points to at t = 0). The faces of a sheet deform and turn within a step: a point that ends
/// on the other side of the sheet, moving linearly with its corners, met one of them; a test in
/// each face's own translating frame can pass by the crease between two faces moving apart.
/// The coplanarity condition is a cubic in t; it is split at its turning points into monotone
/// pieces and each sign change bisected.
template <typename T>
struct SheetMeeting {
  bool meets = false;
  T t = T(0), wb = T(0), wc = T(0);
  T side = T(1);
};

template <typename T>
KF_HD KF_INLINE SheetMeeting<T>
point_meets_moving_triangle(const Vec3<T>& p0, const Vec3<T>& p1, const Vec3<T>& a0,
                            const Vec3<T>& a1, const Vec3<T>& b0, const Vec3<T>& b1,
                            const Vec3<T>& c0, const Vec3<T>& c1, T slack_bary = T(1e-5)) {
  SheetMeeting<T> out;
  // Relative to corner a: e1 = b - a, e2 = c - a, q = p - a, each x0 + t dx.
  const Vec3<T> E1 = b0 - a0, E2 = c0 - a0, Q = p0 - a0;
  const Vec3<T> dE1 = (b1 - a1) - E1, dE2 = (c1 - a1) - E2, dQ = (p1 - a1) - Q;
  // n(t) = cross(e1, e2) = n0 + t n1 + t^2 n2; f(t) = n(t) . q(t) = k0 + k1 t + k2 t^2 + k3 t^3.
  const Vec3<T> n0 = cross(E1, E2), n1 = cross(E1, dE2) + cross(dE1, E2), n2 = cross(dE1, dE2);
  const T k0 = dot(n0, Q), k1 = dot(n1, Q) + dot(n0, dQ), k2 = dot(n2, Q) + dot(n1, dQ),
          k3 = dot(n2, dQ);
  auto f = [&](T t) { return ((k3 * t + k2) * t + k1) * t + k0; };
  // Breakpoints: 0, the turning points of f inside (0, 1) in order, 1.
  T br[4];
  int nb = 0;
  br[nb++] = T(0);
  {
    // f'(t) = k1 + 2 k2 t + 3 k3 t^2.
    const T A = T(3) * k3, B = T(2) * k2, C = k1;
    T r0 = T(2), r1 = T(2);
    if (A != T(0)) {
      const T disc = B * B - T(4) * A * C;
      if (disc > T(0)) {
        const T sq = ksqrt(disc);
        // The stable pair of roots (no cancellation).
        const T qq = B > T(0) ? T(-0.5) * (B + sq) : T(-0.5) * (B - sq);
        r0 = qq / A;
        r1 = qq != T(0) ? C / qq : T(2);
      }
    } else if (B != T(0)) {
      r0 = -C / B;
    }
    if (r0 > r1) {
      const T tmp = r0;
      r0 = r1;
      r1 = tmp;
    }
    if (r0 > T(0) && r0 < T(1))
      br[nb++] = r0;
    if (r1 > T(0) && r1 < T(1) && r1 != r0)
      br[nb++] = r1;
  }
  br[nb++] = T(1);
  const T f0 = f(T(0));
  if (f0 == T(0))
    return out; // in the plane at the start: on the face, not through it (the guard's landings
                // lie a gap off it)
  for (int k = 0; k + 1 < nb; ++k) {
    T lo = br[k], hi = br[k + 1];
    T flo = f(lo), fhi = f(hi);
    if ((flo > T(0) && fhi > T(0)) || (flo < T(0) && fhi < T(0)))
      continue;
    // Bisect the sign change (a zero at lo, a turning point touching the plane, is the root).
    if (flo != T(0)) {
      for (int it = 0; it < 64 && hi - lo > T(4) * std::numeric_limits<T>::epsilon(); ++it) {
        const T mid = T(0.5) * (lo + hi);
        const T fm = f(mid);
        if ((fm > T(0)) == (flo > T(0)) && fm != T(0)) {
          lo = mid;
          flo = fm;
        } else {
          hi = mid;
        }
      }
    }
    const T t = flo == T(0) ? lo : hi;
    // Inside the triangle at t: q = wb e1 + wc e2 (least squares in its plane).
    const Vec3<T> e1 = E1 + dE1 * t, e2 = E2 + dE2 * t, q = Q + dQ * t;
    const T d00 = dot(e1, e1), d01 = dot(e1, e2), d11 = dot(e2, e2), d20 = dot(q, e1),
            d21 = dot(q, e2);
    const T den = d00 * d11 - d01 * d01;
    if (!(den > T(0)))
      continue; // a degenerate face
    const T wb = (d11 * d20 - d01 * d21) / den, wc = (d00 * d21 - d01 * d20) / den;
    if (wb < -slack_bary || wc < -slack_bary || wb + wc > T(1) + slack_bary)
      continue;
    out.meets = true;
    out.t = t;
    out.wb = wb;
    out.wc = wc;
    out.side = f0 > T(0) ? T(1) : T(-1);
    return out;
  }
  return out;
}

/// Whether the box of p0, p1 overlaps the box of the six corner positions (per axis), widened by
/// 1e-4 of the corners' box.
template <typename T>
KF_HD KF_INLINE bool boxes_overlap(const Vec3<T>& p0, const Vec3<T>& p1, const Vec3<T>& a0,
                                   const Vec3<T>& a1, const Vec3<T>& b0, const Vec3<T>& b1,
                                   const Vec3<T>& c0, const Vec3<T>& c1) {
  auto axis = [](T q0, T q1, T u0, T u1, T v0, T v1, T w0, T w1) {
    const T lo = kmin(kmin(kmin(u0, u1), kmin(v0, v1)), kmin(w0, w1));
    const T hi = kmax(kmax(kmax(u0, u1), kmax(v0, v1)), kmax(w0, w1));
    // Widened past the meeting's barycentric slack (1e-5 of an edge).
    const T pad = T(1e-4) * (hi - lo);
    return kmax(q0, q1) >= lo - pad && kmin(q0, q1) <= hi + pad;
  };
  return axis(p0.x, p1.x, a0.x, a1.x, b0.x, b1.x, c0.x, c1.x) &&
         axis(p0.y, p1.y, a0.y, a1.y, b0.y, b1.y, c0.y, c1.y) &&
         axis(p0.z, p1.z, a0.z, a1.z, b0.z, b1.z, c0.z, c1.z);
}

/// The sheet's faces as the guard reads them: per face its three knit points by mesh index, per
/// mesh index its faces (CSR), and each mesh index's local point (null: the identity, one rank;
/// kSheetAbsent: not on this rank, and a face with such a point is not tested here).
inline constexpr std::uint32_t kSheetAbsent = 0xFFFFFFFFu;
struct SheetFacesView {
  const std::uint32_t* vertex = nullptr; // 3 per face
  const std::uint32_t* offsets = nullptr;
  const std::uint32_t* faces = nullptr;
  const std::uint32_t* local_of_id = nullptr;
  KF_HD KF_INLINE std::uint32_t local(std::uint32_t id) const {
    return local_of_id ? local_of_id[id] : id;
  }
};

/// The guard's reaction sums (per knit point, kSheetSumWidth unsigned 64-bit values): how many
/// particles met one of its faces, then its velocity change in fixed point (x, y, z). Integer sums
/// are exact in any order: the threads' order, and how many ranks add to a point, change nothing.
inline constexpr unsigned kSheetSumWidth = 4;
/// Fixed point: value / quantum rounded, two's complement in 64 bits (NaN reads as 0: the fluid
/// particle it came from is then NaN itself, which the watchdog reports).
template <typename T>
KF_HD KF_INLINE std::uint64_t sheet_fixed(T value, T inv_quantum) {
  double q = double(value) * double(inv_quantum);
  const double most = 4.0e18; // under 2^63
  q = q == q ? (q > most ? most : (q < -most ? -most : q)) : 0.0;
  return static_cast<std::uint64_t>(static_cast<std::int64_t>(llrint(q)));
}
template <typename T>
KF_HD KF_INLINE T sheet_unfixed(std::uint64_t value, T quantum) {
  return T(double(static_cast<std::int64_t>(value)) * double(quantum));
}

/// Where a particle met the sheet (the detection's output, per fluid particle): the face
/// (kSheetAbsent: none, or a face collapsed to a line), its corners' weights there (a, b, c: non-
/// negative, summing to 1) and the face's unit normal toward the side the particle came from.
template <typename T>
struct SheetHits {
  std::uint32_t* face;
  Vec3<T>* w;
  Vec3<T>* n;
};

/// One fluid particle after its drift: its step against the faces of the knit points near it,
/// each face's corners moving linearly over the step (point_meets_moving_triangle); at the
/// earliest meeting (ties: the lowest face) it goes back to its side, `gap` off the face, and
/// the meeting is recorded (hits) with a count on each corner (sums[kSheetSumWidth k], particles
/// `counted` flags, or all) for the reaction that follows. Returns 1 when it was put back (and
/// counted). Every face is tested by each of its points found: the earliest meeting does not
/// depend on the order the grid gives them (N ranks find what one rank finds).
template <typename T>
struct SheetGuardEvaluator {
  Vec3<T>* x; // fluid, after the drift
  Vec3<T>* v;
  const std::uint32_t* counted; // null: all; else 1 for the particles counted (owned)
  const Vec3<T>* kx;            // knit, local order, at the step's end
  const Vec3<T>* kx0;           // and at its start
  const std::uint64_t* kid;
  CellView<T> cells;         // the coupling's knit grid
  const std::uint32_t* perm; // grid slot -> local knit point
  SheetFacesView sheet;
  const T* extent; // the faces' SheetExtent (device memory, kSheetExtentValues)
  // The coupling's flags from the step's start (null: none): a particle with no knit point in
  // its 27 cells then had none within a cell of where its step began.
  const std::uint32_t* near;
  SheetHits<T> hits;
  std::uint64_t* sums; // kSheetSumWidth per local knit point, zero before the pass
  T dt, moved, gap;

  KF_HD std::uint64_t operator()(std::size_t j) const {
    hits.face[j] = kSheetAbsent;
    const Vec3<T> p1 = x[j];
    const Vec3<T> vj = v[j];
    // Where it met a face at time t it was within |v| dt of p1, and the face's corners within
    // `step` of where they end, its edges within 2 steps of their lengths now; a point inside
    // a triangle lies within its longest edge over sqrt 3 of a corner (the equilateral's centre
    // is the farthest case).
    const T step = extent[1];
    const T reach =
        (extent[0] + T(2) * step) * T(0.5773502691896258) + ksqrt(norm2(vj)) * dt + step;
    // Far from every face (outside the faces' box grown by the reach): nothing to meet.
    const GridGeometry<T>& g = cells.geo;
    const Vec3<T> top{g.origin.x + g.cell * T(g.nx), g.origin.y + g.cell * T(g.ny),
                      g.origin.z + g.cell * T(g.nz)};
    if (p1.x < top.x - extent[5] - reach || p1.y < top.y - extent[6] - reach ||
        p1.z < top.z - extent[7] - reach || p1.x > g.origin.x + extent[2] + reach ||
        p1.y > g.origin.y + extent[3] + reach || p1.z > g.origin.z + extent[4] + reach)
      return 0;
    // No knit point within a cell of p0 at the sort, so none within cell - moved now.
    if (near && !near[j] && reach + ksqrt(norm2(vj)) * dt < g.cell - moved)
      return 0;
    const T reach2 = reach * reach;
    // The grid's points moved up to `moved` since its sort: the walk reaches that much farther.
    CellView<T> walk = cells; // (`near` is the flags)
    const T spans = (reach + moved) / g.cell;
    walk.span = spans < T(1) ? 1 : (spans < T(8) ? int(spans) + 1 : 8);
    const Vec3<T> p0 = p1 - vj * dt; // where the drift started
    T best_t = T(2);
    std::uint32_t best = kSheetAbsent, ba = 0, bb = 0, bc = 0;
    SheetMeeting<T> bm;
    walk.for_each_candidate(p1, [&](std::uint32_t slot) {
      const std::uint32_t k = perm[slot];
      if (!(norm2(kx[k] - p1) <= reach2))
        return;
      const std::uint32_t id = static_cast<std::uint32_t>(kid[k]);
      for (std::uint32_t q = sheet.offsets[id]; q < sheet.offsets[id + 1]; ++q) {
        const std::uint32_t f = sheet.faces[q];
        const std::uint32_t a = sheet.local(sheet.vertex[3 * f]),
                            b = sheet.local(sheet.vertex[3 * f + 1]),
                            c = sheet.local(sheet.vertex[3 * f + 2]);
        if (a == kSheetAbsent || b == kSheetAbsent || c == kSheetAbsent)
          continue;
        // The face's corners and the particle each move linearly: where they meet lies in the
        // box of the corners' six positions and in that of the particle's two (most faces
        // near a particle are outside its short step's box: no cubic for them).
        if (!boxes_overlap(p0, p1, kx0[a], kx[a], kx0[b], kx[b], kx0[c], kx[c]))
          continue;
        const SheetMeeting<T> m =
            point_meets_moving_triangle(p0, p1, kx0[a], kx[a], kx0[b], kx[b], kx0[c], kx[c]);
        if (m.meets && (m.t < best_t || (m.t == best_t && f < best))) {
          best_t = m.t;
          best = f;
          bm = m;
          ba = a;
          bb = b;
          bc = c;
        }
      }
    });
    if (best == kSheetAbsent)
      return 0;
    const std::uint64_t counts = counted && !counted[j] ? 0 : 1;
    // Back to the side it came from, a gap off the face where it met it (at the step's end).
    const Vec3<T> e1 = kx[bb] - kx[ba], e2 = kx[bc] - kx[ba];
    Vec3<T> n = cross(e1, e2);
    const T nn = norm2(n);
    if (!(nn > T(0))) { // the face collapsed: back where the drift started, no reaction
      x[j] = p0;
      return counts;
    }
    n = n * (bm.side / ksqrt(nn));
    x[j] = kx[ba] + e1 * bm.wb + e2 * bm.wc + n * gap;
    // The weights within the face's closed bounds (the meeting's slack lets them stray by 1e-5).
    T wb = kmax(bm.wb, T(0)), wc = kmax(bm.wc, T(0));
    if (wb + wc > T(1)) {
      const T s = T(1) / (wb + wc);
      wb *= s;
      wc *= s;
    }
    hits.face[j] = best;
    hits.w[j] = Vec3<T>{T(1) - wb - wc, wb, wc};
    hits.n[j] = n;
    if (counts) {
      exec::atomic_add(sums + kSheetSumWidth * ba, 1);
      exec::atomic_add(sums + kSheetSumWidth * bb, 1);
      exec::atomic_add(sums + kSheetSumWidth * bc, 1);
    }
    return counts;
  }
};

/// The reaction (after the detection, the counts complete on every rank): a particle that met a
/// face and approaches it (normal speeds u of the particle, uf of the face's point, the corners'
/// velocities now) meets it inelastically: its normal speed becomes the common one of itself
/// (mass m) and the face's point, whose mass is the corners' by their weights, each corner's
/// mass split among the k particles meeting its faces (Jacobi with mass splitting): 1/M = sum
/// w_i^2 k_i / m_i over free corners (a pinned one is immovable). The particle's impulse J goes
/// to the corners as -w_i J, as a velocity change -w_i J / m_i summed in fixed point (counted
/// particles only: a ghost's owner adds its share). The split makes k equal particles on one
/// corner end at the speed of one inelastic collision of them all with it; each contact loses
/// energy in its split system and the corner takes the mean of its copies, so the kinetic
/// energy never rises (with immovable corners the particle takes the face's normal speed).
template <typename T>
struct SheetReactionEvaluator {
  Vec3<T>* v;
  const T* m;
  const std::uint32_t* counted;
  SheetHits<T> hits;
  const Vec3<T>* kv; // knit, local order
  const T* km;
  const std::uint32_t* handle; // kNoHandle: free
  SheetFacesView sheet;
  std::uint64_t* sums;
  T inv_quantum;

  KF_HD void operator()(std::size_t j) const {
    const std::uint32_t f = hits.face[j];
    if (f == kSheetAbsent)
      return;
    const std::uint32_t c[3] = {sheet.local(sheet.vertex[3 * f]),
                                sheet.local(sheet.vertex[3 * f + 1]),
                                sheet.local(sheet.vertex[3 * f + 2])};
    const Vec3<T> wv = hits.w[j], n = hits.n[j];
    const T w[3] = {wv.x, wv.y, wv.z};
    const Vec3<T> vj = v[j];
    T uf = T(0), inv_mass = T(0);
    for (int e = 0; e < 3; ++e) {
      uf += w[e] * dot(kv[c[e]], n);
      if (handle[c[e]] == kNoHandle) {
        const std::uint64_t k = sums[kSheetSumWidth * c[e]];
        inv_mass += w[e] * w[e] * T(k > 0 ? k : 1) / km[c[e]];
      }
    }
    const T closing = dot(vj, n) - uf; // < 0: approaching the face (n points to its side)
    if (!(closing < T(0)))
      return;
    const T mj = m[j];
    const T du = -closing / (T(1) + mj * inv_mass);
    v[j] = vj + n * du;
    if (counted && !counted[j])
      return;
    for (int e = 0; e < 3; ++e) {
      if (handle[c[e]] != kNoHandle || w[e] == T(0))
        continue;
      const Vec3<T> dv = n * (-w[e] * mj * du / km[c[e]]);
      std::uint64_t* s = sums + kSheetSumWidth * c[e];
      exec::atomic_add(s + 1, sheet_fixed(dv.x, inv_quantum));
      exec::atomic_add(s + 2, sheet_fixed(dv.y, inv_quantum));
      exec::atomic_add(s + 3, sheet_fixed(dv.z, inv_quantum));
    }
  }
};

/// The knit's side of the reaction (each owned point, after the sums reached it from every
/// rank): its summed velocity change.
template <typename T>
struct SheetKickEvaluator {
  Vec3<T>* kv;
  const std::uint32_t* handle;
  const std::uint64_t* sums;
  T quantum;
  KF_HD void operator()(std::size_t i) const {
    const std::uint64_t* s = sums + kSheetSumWidth * i;
    if (s[0] == 0 || handle[i] != kNoHandle)
      return;
    kv[i] = kv[i] + Vec3<T>{sheet_unfixed(s[1], quantum), sheet_unfixed(s[2], quantum),
                            sheet_unfixed(s[3], quantum)};
  }
};

/// What the guard's reach needs of the faces a rank holds, as non-negative maxima (max_into_each):
/// [0] the longest edge now, [1] the farthest a corner moved over the step, [2..4] how far the
/// corners reach above the grid's origin along x, y, z, [5..7] how far below its top (a corner
/// outside the grid counts as on its edge: the box only grows). A NaN reads as huge.
inline constexpr unsigned kSheetExtentValues = 8;
template <typename T>
struct SheetExtent {
  const Vec3<T>* kx;
  const Vec3<T>* kx0;
  SheetFacesView sheet;
  GridGeometry<T> geo;
  KF_HD exec::Maxima<T, kSheetExtentValues> operator()(std::size_t f) const {
    exec::Maxima<T, kSheetExtentValues> m{};
    const std::uint32_t c[3] = {sheet.local(sheet.vertex[3 * f]),
                                sheet.local(sheet.vertex[3 * f + 1]),
                                sheet.local(sheet.vertex[3 * f + 2])};
    if (c[0] == kSheetAbsent || c[1] == kSheetAbsent || c[2] == kSheetAbsent)
      return m;
    const Vec3<T> top{geo.origin.x + geo.cell * T(geo.nx), geo.origin.y + geo.cell * T(geo.ny),
                      geo.origin.z + geo.cell * T(geo.nz)};
    auto put = [&m](unsigned k, T v) {
      v = v == v ? v : T(1e30);
      if (v > m.v[k])
        m.v[k] = v;
    };
    for (int e = 0; e < 3; ++e) {
      const Vec3<T> a = kx[c[e]], b = kx[c[(e + 1) % 3]];
      put(0, ksqrt(norm2(b - a)));
      put(1, ksqrt(norm2(a - kx0[c[e]])));
      put(2, a.x - geo.origin.x);
      put(3, a.y - geo.origin.y);
      put(4, a.z - geo.origin.z);
      put(5, top.x - a.x);
      put(6, top.y - a.y);
      put(7, top.z - a.z);
    }
    return m;
  }
};

} // namespace kf
