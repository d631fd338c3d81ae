#pragma once
// The tunnelling guard's geometry (P8 stage 5; docs/ARCHITECTURE.md "Tunnelling guard"): does a
// fluid particle's step cross a face of the knit's sheet, and where does it go back to. Written
// once for both backends.
#include "core/HostDevice.hpp"
#include "core/Math.hpp"
#include "core/Vec3.hpp"

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

} // namespace kf
