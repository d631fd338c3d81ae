#pragma once
// Precision-preserving math for kernels: unqualified sqrt(float) on the host would promote to
// double; these overloads keep float in float on both backends.
#include "core/HostDevice.hpp"

#include <cmath>

namespace kf {

KF_HD KF_INLINE float ksqrt(float x) {
#if defined(__CUDA_ARCH__)
  return sqrtf(x);
#else
  return std::sqrt(x);
#endif
}
KF_HD KF_INLINE double ksqrt(double x) {
#if defined(__CUDA_ARCH__)
  return ::sqrt(x);
#else
  return std::sqrt(x);
#endif
}
KF_HD KF_INLINE float kfloor(float x) {
#if defined(__CUDA_ARCH__)
  return floorf(x);
#else
  return std::floor(x);
#endif
}
KF_HD KF_INLINE double kfloor(double x) {
#if defined(__CUDA_ARCH__)
  return ::floor(x);
#else
  return std::floor(x);
#endif
}
KF_HD KF_INLINE float kpow(float x, float y) {
#if defined(__CUDA_ARCH__)
  return powf(x, y);
#else
  return std::pow(x, y);
#endif
}
KF_HD KF_INLINE double kpow(double x, double y) {
#if defined(__CUDA_ARCH__)
  return ::pow(x, y);
#else
  return std::pow(x, y);
#endif
}
template <typename T>
KF_HD KF_INLINE T kabs(T x) {
  return x < T(0) ? -x : x;
}

template <typename T>
KF_HD KF_INLINE T kmax(T a, T b) {
  return a < b ? b : a;
}
template <typename T>
KF_HD KF_INLINE T kmin(T a, T b) {
  return b < a ? b : a;
}

} // namespace kf
