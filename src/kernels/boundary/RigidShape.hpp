#pragma once
// Rigid shapes as signed distance functions: d > 0 on the free side (where fluid and cloth may be),
// d < 0 inside the solid. `normal` points to the free side. Used by the boundary guard, the
// boundary samplers and the knit's contact with solids.
//
// A plain, trivially copyable struct passed by value (or as a device array) into kernels; a mesh
// shape points at its sampled signed distance, which the shapes' owner keeps alive on the same
// backend (domain/RigidShapes).
#include "core/HostDevice.hpp"
#include "core/Math.hpp"
#include "core/Vec3.hpp"

#include <cstdint>
#include <type_traits>

namespace kf {

enum class ShapeKind : std::uint32_t { Plane = 0, Box = 1, Sphere = 2, Container = 3, Mesh = 4 };

template <typename T>
struct RigidShape {
  ShapeKind kind = ShapeKind::Box;
  Vec3<T> a{};     // plane: point, box/container: min, sphere: centre, mesh: first grid node
  Vec3<T> b{};     // plane: unit normal, box/container: max, mesh: last grid node
  T radius = T(0); // sphere
  std::uint32_t walls = 0x3F; // container: bit k set = wall k closed (x-, x+, y-, y+, z-, z+)
  Vec3<T> velocity{};         // prescribed translation
  Vec3<T> offset{};           // translation at the current time (velocity * t)

  const T* sdf = nullptr;            // mesh: signed distance at the grid nodes, x fastest
  T cell = T(0);                     // mesh: grid spacing
  std::uint32_t dims[3] = {0, 0, 0}; // mesh: grid nodes along x, y, z (>= 2 each)

  KF_HD KF_INLINE T distance(const Vec3<T>& x_world, Vec3<T>& normal) const {
    const Vec3<T> x = x_world - offset;
    switch (kind) {
    case ShapeKind::Plane:
      normal = b;
      return dot(x - a, b);
    case ShapeKind::Sphere: {
      const Vec3<T> d = x - a;
      const T r = norm(d);
      normal = r > T(0) ? d * (T(1) / r) : Vec3<T>{T(0), T(0), T(1)};
      return r - radius;
    }
    case ShapeKind::Box:
      return box_distance(x, normal);
    case ShapeKind::Container:
      return container_distance(x, normal);
    case ShapeKind::Mesh:
      return grid_distance(x, normal);
    }
    normal = {T(0), T(0), T(1)};
    return T(1);
  }

  /// Whether x lies at least `margin` outside the solid, from a bound cheaper than
  /// distance(): true means distance(x) >= margin; false means maybe not. Why: the fluid's
  /// contact test (RigidContact) runs for every particle and shape at every step, and nearly all
  /// are far from every solid; distance() pays a square root and a division for the normal.
  KF_HD KF_INLINE bool clear_by(const Vec3<T>& x_world, T margin) const {
    const Vec3<T> x = x_world - offset;
    switch (kind) {
    case ShapeKind::Plane:
      return dot(x - a, b) >= margin;
    case ShapeKind::Sphere: {
      const T reach = radius + margin;
      return reach <= T(0) || norm2(x - a) >= reach * reach;
    }
    case ShapeKind::Box: { // outside along one axis by q: at least q away
      const Vec3<T> q = box_excess(x);
      return kmax(kmax(q.x, q.y), q.z) >= margin;
    }
    case ShapeKind::Container: { // the nearest closed wall
      T d[6];
      wall_gaps(x, d);
      bool clear = true;
      for (int w = 0; w < 6; ++w)
        clear = clear && (!(walls >> w & 1u) || d[w] >= margin);
      return clear;
    }
    case ShapeKind::Mesh:
      return false;
    }
    return false;
  }

private:
  /// Trilinear interpolation of the sampled distance, normal along its gradient. Beyond the
  /// grid: the distance to the grid's box plus the value at the nearest point of the box, so it
  /// stays positive (the grid has a margin of free space) and grows away from the mesh.
  KF_HD KF_INLINE T grid_distance(const Vec3<T>& x, Vec3<T>& normal) const {
    const T xs[3] = {x.x, x.y, x.z}, lo[3] = {a.x, a.y, a.z}, hi[3] = {b.x, b.y, b.z};
    const T inv = T(1) / cell;
    T out[3], t[3];
    std::uint32_t i[3];
    for (int k = 0; k < 3; ++k) {
      const T c = xs[k] < lo[k] ? lo[k] : (xs[k] > hi[k] ? hi[k] : xs[k]);
      out[k] = xs[k] - c;
      const T f = (c - lo[k]) * inv;
      const std::uint32_t last = dims[k] - 2; // index of the last cell
      const std::uint32_t ci = f > T(0) ? static_cast<std::uint32_t>(f) : 0u;
      i[k] = ci < last ? ci : last;
      const T frac = f - static_cast<T>(i[k]);
      t[k] = frac < T(0) ? T(0) : (frac > T(1) ? T(1) : frac);
    }
    const std::uint32_t sx = 1, sy = dims[0], sz = dims[0] * dims[1];
    const T* v = sdf + (i[0] * sx + i[1] * sy + i[2] * sz);
    const T v000 = v[0], v100 = v[sx], v010 = v[sy], v110 = v[sx + sy];
    const T v001 = v[sz], v101 = v[sx + sz], v011 = v[sy + sz], v111 = v[sx + sy + sz];
    // Along x on the four edges, then y, then z; the gradient from the same differences.
    const T e00 = v000 + (v100 - v000) * t[0], e10 = v010 + (v110 - v010) * t[0];
    const T e01 = v001 + (v101 - v001) * t[0], e11 = v011 + (v111 - v011) * t[0];
    const T f0 = e00 + (e10 - e00) * t[1], f1 = e01 + (e11 - e01) * t[1];
    const T value = f0 + (f1 - f0) * t[2];
    const T u1 = T(1) - t[1], u2 = T(1) - t[2];
    T g[3] = {((v100 - v000) * u1 * u2 + (v110 - v010) * t[1] * u2 + (v101 - v001) * u1 * t[2] +
               (v111 - v011) * t[1] * t[2]) *
                  inv,
              (e10 - e00) * u2 * inv + (e11 - e01) * t[2] * inv, (f1 - f0) * inv};
    const T o2 = out[0] * out[0] + out[1] * out[1] + out[2] * out[2];
    T d = value;
    if (o2 > T(0)) { // clamped axes follow the distance to the box, the others the samples
      const T o = ksqrt(o2);
      for (int k = 0; k < 3; ++k)
        if (out[k] != T(0))
          g[k] = out[k] / o;
      d += o;
    }
    const T gl = ksqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]);
    normal = gl > T(0) ? Vec3<T>{g[0] / gl, g[1] / gl, g[2] / gl} : Vec3<T>{T(0), T(0), T(1)};
    return d;
  }

  /// How far x lies beyond a box's faces along each axis (negative inside).
  KF_HD KF_INLINE Vec3<T> box_excess(const Vec3<T>& x) const {
    const Vec3<T> half = (b - a) * T(0.5), p = x - (a + b) * T(0.5);
    return {kabs(p.x) - half.x, kabs(p.y) - half.y, kabs(p.z) - half.z};
  }
  /// x's distances to a container's six wall planes (x-, x+, y-, y+, z-, z+), positive inside.
  KF_HD KF_INLINE void wall_gaps(const Vec3<T>& x, T (&d)[6]) const {
    d[0] = x.x - a.x, d[1] = b.x - x.x, d[2] = x.y - a.y;
    d[3] = b.y - x.y, d[4] = x.z - a.z, d[5] = b.z - x.z;
  }
  KF_HD KF_INLINE T box_distance(const Vec3<T>& x, Vec3<T>& normal) const {
    const Vec3<T> p = x - (a + b) * T(0.5), e = box_excess(x);
    const T q[3] = {e.x, e.y, e.z};
    const T s[3] = {p.x < T(0) ? T(-1) : T(1), p.y < T(0) ? T(-1) : T(1),
                    p.z < T(0) ? T(-1) : T(1)};
    if (q[0] <= T(0) && q[1] <= T(0) && q[2] <= T(0)) { // inside: leave by the nearest face
      int k = q[0] > q[1] ? (q[0] > q[2] ? 0 : 2) : (q[1] > q[2] ? 1 : 2);
      normal = {k == 0 ? s[0] : T(0), k == 1 ? s[1] : T(0), k == 2 ? s[2] : T(0)};
      return q[k];
    }
    const Vec3<T> o{q[0] > T(0) ? q[0] * s[0] : T(0), q[1] > T(0) ? q[1] * s[1] : T(0),
                    q[2] > T(0) ? q[2] * s[2] : T(0)};
    const T d = norm(o);
    normal = o * (T(1) / d);
    return d;
  }
  KF_HD KF_INLINE T container_distance(const Vec3<T>& x, Vec3<T>& normal) const {
    T d[6];
    wall_gaps(x, d);
    T best = T(1e30);
    int k = -1;
    for (int w = 0; w < 6; ++w)
      if ((walls >> w & 1u) && d[w] < best) {
        best = d[w];
        k = w;
      }
    const T sign = (k & 1) ? T(-1) : T(1);
    normal = {k / 2 == 0 ? sign : T(0), k / 2 == 1 ? sign : T(0), k / 2 == 2 ? sign : T(0)};
    return k < 0 ? T(1e30) : best;
  }
};

static_assert(std::is_trivially_copyable_v<RigidShape<float>> &&
              std::is_trivially_copyable_v<RigidShape<double>>);

} // namespace kf
