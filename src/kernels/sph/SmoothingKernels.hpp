#pragma once
// SPH smoothing kernels, all with compact support radius h (W = 0 for r >= h), normalised to
// integrate to 1 in 3D. Each provides W(r), dW/dr(r) and grad W(r_vec) = dW/dr * r_vec / r.
#include "core/HostDevice.hpp"
#include "core/SolverOptions.hpp"
#include "core/Vec3.hpp"

namespace kf {

template <typename T>
struct KernelBase {
  /// Gradient with respect to the first particle's position, for r_vec = x_i - x_j.
  template <typename K>
  KF_HD KF_INLINE static Vec3<T> grad_of(const K& k, const Vec3<T>& r_vec, T r) {
    if (r <= T(0) || r >= k.h)
      return {T(0), T(0), T(0)};
    return r_vec * (k.dWdr(r) / r);
  }
};

/// Müller et al. 2003 spiky kernel, the paper's Eq. 5; its gradient is Eq. 6 with r normalised
/// (the paper prints (h - r)^2 r where r/|r| is meant).
template <typename T>
struct SpikyKernel : KernelBase<T> {
  T h, c; // c = 15 / (pi h^6)
  KF_HD explicit SpikyKernel(T h_) : h(h_), c(T(15) / (T(3.14159265358979323846) * pow6(h_))) {}
  KF_HD KF_INLINE static T pow6(T x) { return x * x * x * x * x * x; }
  // Selects, not branches (here and below): in a neighbour loop the lanes of a warp fall on
  // different sides, and branches made them take both in turn.
  KF_HD KF_INLINE T W(T r) const {
    const T d = h - r;
    return r >= h ? T(0) : c * d * d * d;
  }
  KF_HD KF_INLINE T dWdr(T r) const {
    const T d = h - r;
    return r >= h ? T(0) : T(-3) * c * d * d;
  }
  KF_HD KF_INLINE Vec3<T> grad(const Vec3<T>& r_vec, T r) const {
    return this->grad_of(*this, r_vec, r);
  }
};

/// Cubic B-spline (Monaghan 1992) written with support h (smoothing length h/2).
template <typename T>
struct CubicSplineKernel : KernelBase<T> {
  T h, inv_h, c; // c = 8 / (pi h^3)
  KF_HD explicit CubicSplineKernel(T h_)
      : h(h_), inv_h(T(1) / h_), c(T(8) / (T(3.14159265358979323846) * h_ * h_ * h_)) {}
  KF_HD KF_INLINE T W(T r) const {
    const T q = r * inv_h;
    const T d = T(1) - q;
    const T inner = c * (T(6) * (q * q * q - q * q) + T(1));
    const T outer = c * T(2) * d * d * d;
    const T v = q <= T(0.5) ? inner : outer;
    return q >= T(1) ? T(0) : v;
  }
  KF_HD KF_INLINE T dWdr(T r) const {
    const T q = r * inv_h;
    const T d = T(1) - q;
    const T inner = c * inv_h * T(6) * (T(3) * q * q - T(2) * q);
    const T outer = c * inv_h * T(-6) * d * d;
    const T v = q <= T(0.5) ? inner : outer;
    return q >= T(1) ? T(0) : v;
  }
  KF_HD KF_INLINE Vec3<T> grad(const Vec3<T>& r_vec, T r) const {
    return this->grad_of(*this, r_vec, r);
  }
};

/// Wendland C2 (Wendland 1995; Dehnen & Aly 2012) in 3D with support h.
template <typename T>
struct WendlandC2Kernel : KernelBase<T> {
  T h, inv_h, c; // c = 21 / (2 pi h^3)
  KF_HD explicit WendlandC2Kernel(T h_)
      : h(h_), inv_h(T(1) / h_), c(T(21) / (T(2) * T(3.14159265358979323846) * h_ * h_ * h_)) {}
  KF_HD KF_INLINE T W(T r) const {
    const T q = r * inv_h;
    const T d = T(1) - q;
    const T d2 = d * d;
    return q >= T(1) ? T(0) : c * d2 * d2 * (T(1) + T(4) * q);
  }
  KF_HD KF_INLINE T dWdr(T r) const {
    const T q = r * inv_h;
    const T d = T(1) - q;
    return q >= T(1) ? T(0) : c * inv_h * T(-20) * q * d * d * d;
  }
  KF_HD KF_INLINE Vec3<T> grad(const Vec3<T>& r_vec, T r) const {
    return this->grad_of(*this, r_vec, r);
  }
};

/// Calls f(kernel) with the kernel object the scene selected: one switch instead of one per stage.
template <typename T, typename F>
decltype(auto) with_kernel(KernelType type, T h, F&& f) {
  switch (type) {
  case KernelType::CubicSpline:
    return f(CubicSplineKernel<T>(h));
  case KernelType::WendlandC2:
    return f(WendlandC2Kernel<T>(h));
  case KernelType::Spiky:
    break;
  }
  return f(SpikyKernel<T>(h));
}

} // namespace kf
