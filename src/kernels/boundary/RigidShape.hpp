#pragma once
// Rigid shapes as signed distance functions: d > 0 on the free side (where fluid and cloth may be),
// d < 0 inside the solid. `normal` points to the free side. Used by the boundary guard and, later,
// by knit-obstacle collisions.
#include "core/HostDevice.hpp"
#include "core/Math.hpp"
#include "core/Vec3.hpp"

#include <cstdint>

namespace kf {

enum class ShapeKind : std::uint32_t { Plane = 0, Box = 1, Sphere = 2, Container = 3 };

template <typename T>
struct RigidShape {
  ShapeKind kind = ShapeKind::Box;
  Vec3<T> a{};     // plane: point, box/container: min, sphere: centre
  Vec3<T> b{};     // plane: unit normal, box/container: max
  T radius = T(0); // sphere
  std::uint32_t walls = 0x3F; // container: bit k set = wall k closed (x-, x+, y-, y+, z-, z+)
  Vec3<T> velocity{}; // prescribed translation
  Vec3<T> offset{};   // translation at the current time (velocity * t)

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
    case ShapeKind::Box: return box_distance(x, normal);
    case ShapeKind::Container: return container_distance(x, normal);
    }
    normal = {T(0), T(0), T(1)};
    return T(1);
  }

private:
  KF_HD KF_INLINE T box_distance(const Vec3<T>& x, Vec3<T>& normal) const {
    const Vec3<T> c = (a + b) * T(0.5), half = (b - a) * T(0.5), p = x - c;
    const T q[3] = {kabs(p.x) - half.x, kabs(p.y) - half.y, kabs(p.z) - half.z};
    const T s[3] = {p.x < T(0) ? T(-1) : T(1), p.y < T(0) ? T(-1) : T(1), p.z < T(0) ? T(-1) : T(1)};
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
    const T d[6] = {x.x - a.x, b.x - x.x, x.y - a.y, b.y - x.y, x.z - a.z, b.z - x.z};
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

} // namespace kf
