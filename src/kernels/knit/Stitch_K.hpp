#pragma once
// Stitch geometry (paper §3, Eq. 1, Fig. 1b): the twelve bonding points of one stitch as weighted
// sums of the corners of its mesh cell, m1..m4 in the front layer (the paper's layer 1) and
// m'1..m'4 in the back layer (layer 3). m1-m2 is the cell's lower edge (course j), m3-m4 its
// upper edge (course j+1); m1, m3 on the left (wale i), m2, m4 on the right.
//
// In cell coordinates (u right, v up; F front, B back) Eq. 1 puts
//   t1 (1/7, 1) F   t2 (3/14, 2/3) B   t3 (11/14, 2/3) B   t4 (6/7, 1) F      the "head" arc
//   t5 (0, 1) B     t6 (2/7, 1) B      t7 (5/14, 3/4) F    t8 (1/7, 0) F      the left leg
//   t9 (1, 1) B     t10 (5/7, 1) B     t11 (9/14, 3/4) F   t12 (6/7, 0) F     the right leg
// t8 and t12 on the lower edge coincide with t1 and t4 of the cell below, and t9 with t5 of the
// cell to the right, so one course's yarn runs, cell after cell:
//   left leg t5 t6 t7 t8 = (t1 of the cell below) t2 t3 t4 (below) = t12, right leg t11 t10 t9.
// The loop of stitch (i, j) dips through the head arc of cell (i, j-1): that is the interlock.
// A purl stitch is the knit stitch mirrored through the thickness (front and back swapped).
// Derived data (rendering, snapshots); never fed back into the dynamics.
#include "core/HostDevice.hpp"
#include "core/Vec3.hpp"

namespace kf {

inline constexpr int kBondingPoints = 12;

/// Eq. 1: t_{k+1} = sum_c w[c] m_{c+1} (c < 4) + w[c] m'_{c-3} (c >= 4), k = 0..11.
/// t7 and t11 divide by 28 (DESIGN §10); every row sums to 1.
KF_HD KF_INLINE void stitch_weights(int k, double w[8]) {
  constexpr double table[kBondingPoints][8] = {
      {0, 0, 6 / 7., 1 / 7., 0, 0, 0, 0},                    // t1
      {0, 0, 0, 0, 5.5 / 21, 1.5 / 21, 11 / 21., 3 / 21.},   // t2
      {0, 0, 0, 0, 1.5 / 21, 5.5 / 21, 3 / 21., 11 / 21.},   // t3
      {0, 0, 1 / 7., 6 / 7., 0, 0, 0, 0},                    // t4
      {0, 0, 0, 0, 0, 0, 1, 0},                              // t5
      {0, 0, 0, 0, 0, 0, 5 / 7., 2 / 7.},                    // t6
      {4.5 / 28, 2.5 / 28, 13.5 / 28, 7.5 / 28, 0, 0, 0, 0}, // t7
      {6 / 7., 1 / 7., 0, 0, 0, 0, 0, 0},                    // t8
      {0, 0, 0, 0, 0, 0, 0, 1},                              // t9
      {0, 0, 0, 0, 0, 0, 2 / 7., 5 / 7.},                    // t10
      {2.5 / 28, 4.5 / 28, 7.5 / 28, 13.5 / 28, 0, 0, 0, 0}, // t11
      {1 / 7., 6 / 7., 0, 0, 0, 0, 0, 0},                    // t12
  };
  for (int c = 0; c < 8; ++c)
    w[c] = table[k][c];
}

/// Bonding point t_{k+1} of a cell from its front corners m[4] and back corners mb[4]; a purl
/// stitch swaps the layers.
template <typename T>
KF_HD KF_INLINE Vec3<T> bonding_point(int k, const Vec3<T> m[4], const Vec3<T> mb[4], bool purl) {
  double w[8];
  stitch_weights(k, w);
  Vec3<T> p{T(0), T(0), T(0)};
  for (int c = 0; c < 4; ++c) {
    p += (purl ? mb[c] : m[c]) * static_cast<T>(w[c]);
    p += (purl ? m[c] : mb[c]) * static_cast<T>(w[c + 4]);
  }
  return p;
}

/// Uniform Catmull-Rom point between p1 and p2 at s in [0, 1] (p0, p3 the outer neighbours).
template <typename T>
KF_HD KF_INLINE Vec3<T> catmull_rom(const Vec3<T>& p0, const Vec3<T>& p1, const Vec3<T>& p2,
                                    const Vec3<T>& p3, T s) {
  const T s2 = s * s, s3 = s2 * s;
  return (p1 * T(2) + (p2 - p0) * s + (p0 * T(2) - p1 * T(5) + p2 * T(4) - p3) * s2 +
          (p1 * T(3) - p0 - p2 * T(3) + p3) * s3) *
         T(0.5);
}

} // namespace kf
