#pragma once
#include "core/HostDevice.hpp"
#include "core/Math.hpp"
#include "core/SolverOptions.hpp"

#include <cmath>

namespace kf {

/// Equation of state. Linear (the paper): P = k (rho - rho0) with k = c^2. Tait:
/// P = B ((rho/rho0)^gamma - 1), B = rho0 c^2 / gamma. Both have sound speed c at rest density.
template <typename T>
struct Eos {
  EosType type = EosType::Tait;
  T rho0 = T(1000);
  T c2 = T(400); // speed of sound squared
  T gamma = T(7);
  bool clamp_negative = true; // free surfaces: no tension, which would clump particles

  KF_HD KF_INLINE T pressure(T rho) const {
    T p;
    if (type == EosType::Linear) {
      p = c2 * (rho - rho0);
    } else {
      const T B = rho0 * c2 / gamma;
      p = B * (kpow(rho / rho0, gamma) - T(1));
    }
    return (clamp_negative && p < T(0)) ? T(0) : p;
  }
  /// The density a particle keeps when its density is integrated (continuity): where the
  /// pressure is clamped, at least rho0. Below rho0 it would have no pressure anyway, and spray
  /// that expanded would come back (into the water, onto a wall) without pressure until it had
  /// compressed again (docs/PHYSICS.md).
  KF_HD KF_INLINE T kept_density(T rho) const { return clamp_negative && rho < rho0 ? rho0 : rho; }
  /// The density at which the EOS gives pressure p (inverse of pressure() for p >= 0).
  KF_HD KF_INLINE T density(T p) const {
    if (type == EosType::Linear)
      return rho0 + p / c2;
    const T B = rho0 * c2 / gamma;
    return rho0 * kpow(p / B + T(1), T(1) / gamma);
  }
};

} // namespace kf
