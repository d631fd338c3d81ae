#pragma once
#include "core/HostDevice.hpp"
#include "core/Math.hpp"

#include <cmath>

namespace kf {

/// Three-component vector used by every kernel; plain aggregate so arrays of it can live on a GPU.
template <typename T>
struct Vec3 {
  T x, y, z;

  KF_HD KF_INLINE Vec3& operator+=(const Vec3& o) {
    x += o.x;
    y += o.y;
    z += o.z;
    return *this;
  }
  KF_HD KF_INLINE Vec3& operator-=(const Vec3& o) {
    x -= o.x;
    y -= o.y;
    z -= o.z;
    return *this;
  }
  KF_HD KF_INLINE Vec3& operator*=(T s) {
    x *= s;
    y *= s;
    z *= s;
    return *this;
  }
};

template <typename T>
KF_HD KF_INLINE Vec3<T> operator+(Vec3<T> a, const Vec3<T>& b) {
  return a += b;
}
template <typename T>
KF_HD KF_INLINE Vec3<T> operator-(Vec3<T> a, const Vec3<T>& b) {
  return a -= b;
}
template <typename T>
KF_HD KF_INLINE Vec3<T> operator-(const Vec3<T>& a) {
  return {-a.x, -a.y, -a.z};
}
template <typename T>
KF_HD KF_INLINE Vec3<T> operator*(Vec3<T> a, T s) {
  return a *= s;
}
template <typename T>
KF_HD KF_INLINE Vec3<T> operator*(T s, Vec3<T> a) {
  return a *= s;
}
template <typename T>
KF_HD KF_INLINE T dot(const Vec3<T>& a, const Vec3<T>& b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}
template <typename T>
KF_HD KF_INLINE T norm2(const Vec3<T>& a) {
  return dot(a, a);
}
template <typename T>
KF_HD KF_INLINE T norm(const Vec3<T>& a) {
  return ksqrt(norm2(a));
}
template <typename T>
KF_HD KF_INLINE Vec3<T> cross(const Vec3<T>& a, const Vec3<T>& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
template <typename T, typename U>
KF_HD KF_INLINE Vec3<T> vec_cast(const Vec3<U>& a) {
  return {static_cast<T>(a.x), static_cast<T>(a.y), static_cast<T>(a.z)};
}

using Vec3d = Vec3<double>;

/// Three components and a fourth value, aligned so that a kernel loads all four at once (one
/// 16-byte load in float): the SPH passes gather a neighbour's position with its mass, and its
/// velocity with its pressure term, from such pairs (FluidView::xm, vp).
template <typename T>
struct alignas(4 * sizeof(T)) Vec4 {
  T x, y, z, w;
  KF_HD KF_INLINE Vec3<T> xyz() const { return {x, y, z}; }
};

/// The position held by a Vec3 or by a packed (x, w) Vec4: code that reads either kind.
template <typename T>
KF_HD KF_INLINE Vec3<T> position_of(const Vec3<T>& p) {
  return p;
}
template <typename T>
KF_HD KF_INLINE Vec3<T> position_of(const Vec4<T>& p) {
  return p.xyz();
}

} // namespace kf
