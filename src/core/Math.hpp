#pragma once
// Precision-preserving math for kernels: unqualified sqrt(float) on the host would promote to
// double; these overloads keep float in float on both backends.
#include "core/HostDevice.hpp"

#include <cmath>
#include <limits>

namespace kf {

/// NaN read as +infinity (a bound a reduction of maxima over ranks must not lose).
template <typename T>
KF_HD KF_INLINE T nan_as_inf(T v) {
  return v == v ? v : std::numeric_limits<T>::infinity();
}

/// max(s, t) that lets NaN win, so a blown-up value cannot hide in a reduction's maximum.
template <typename T>
KF_HD KF_INLINE T nan_max(T s, T t) {
  return (s != s || t != t) ? (s != s ? s : t) : (s < t ? t : s);
}

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
/// 1 / sqrt(x) for x > 0: one hardware instruction on the GPU (within 2 ulp in float; the
/// neighbour loops' hot paths use it instead of a square root and a division).
KF_HD KF_INLINE float krsqrt(float x) {
#if defined(__CUDA_ARCH__)
  return rsqrtf(x);
#else
  return 1.0f / std::sqrt(x);
#endif
}
KF_HD KF_INLINE double krsqrt(double x) {
#if defined(__CUDA_ARCH__)
  return ::rsqrt(x);
#else
  return 1.0 / std::sqrt(x);
#endif
}
/// Index of the highest set bit of a nonzero word (one FLO on the GPU).
KF_HD KF_INLINE unsigned highest_bit(unsigned w) {
#if defined(__CUDA_ARCH__)
  return static_cast<unsigned>(31 - __clz(static_cast<int>(w)));
#else
  return static_cast<unsigned>(31 - __builtin_clz(w));
#endif
}
/// Index of the lowest set bit of a nonzero word.
KF_HD KF_INLINE unsigned lowest_bit(unsigned w) {
#if defined(__CUDA_ARCH__)
  return static_cast<unsigned>(__ffs(static_cast<int>(w)) - 1);
#else
  return static_cast<unsigned>(__builtin_ctz(w));
#endif
}
/// Number of set bits.
KF_HD KF_INLINE unsigned popcount(unsigned w) {
#if defined(__CUDA_ARCH__)
  return static_cast<unsigned>(__popc(w));
#else
  return static_cast<unsigned>(__builtin_popcount(w));
#endif
}
/// The word's bits in reverse order (bit k to bit 31 - k).
KF_HD KF_INLINE unsigned reverse_bits(unsigned w) {
#if defined(__CUDA_ARCH__)
  return __brev(w);
#else
  w = ((w >> 1) & 0x55555555u) | ((w & 0x55555555u) << 1);
  w = ((w >> 2) & 0x33333333u) | ((w & 0x33333333u) << 2);
  w = ((w >> 4) & 0x0F0F0F0Fu) | ((w & 0x0F0F0F0Fu) << 4);
  w = ((w >> 8) & 0x00FF00FFu) | ((w & 0x00FF00FFu) << 8);
  return (w >> 16) | (w << 16);
#endif
}
/// 1 / x, correctly rounded on both backends (cheaper than a general division on the GPU).
KF_HD KF_INLINE float krcp(float x) {
#if defined(__CUDA_ARCH__)
  return __frcp_rn(x);
#else
  return 1.0f / x;
#endif
}
KF_HD KF_INLINE double krcp(double x) {
#if defined(__CUDA_ARCH__)
  return __drcp_rn(x);
#else
  return 1.0 / x;
#endif
}
/// 1 / x within 2 ulp for normal x (one hardware reciprocal and a multiply on the GPU; the
/// correctly rounded krcp adds a refinement and a slow-path branch). For per-pair factors whose
/// rounding does not matter: the CPU computes the exact quotient, and GPU results are compared
/// with the CPU's within tolerances anyway.
KF_HD KF_INLINE float krcp_fast(float x) {
#if defined(__CUDA_ARCH__)
  return __fdividef(1.0f, x);
#else
  return 1.0f / x;
#endif
}
KF_HD KF_INLINE double krcp_fast(double x) {
  return krcp(x);
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
