#pragma once
// What the watchdog (domain/Watchdog) reads of a particle set, in one pass and one small read:
// the set's kinetic and gravitational energy and its largest speed and density. Cheap enough to
// run every few dozen steps on a large scene, unlike the diagnostics (host copies, the knit's
// spring energies).
#include "core/Vec3.hpp"
#include "kernels/exec/Algorithms.hpp"

#include <cstdint>

namespace kf {

/// Sums in double (a float sum over a million particles would lose the rise it looks for);
/// maxima let NaN win, so a blown-up particle cannot hide.
struct WatchSums {
  double mass = 0;      // sum m [kg]
  double kinetic = 0;   // sum 1/2 m |v|^2 [J]
  double potential = 0; // sum m |g| height above the reference [J]
  double max_speed2 = 0;
  double max_density = 0; // 0 for a set without density
};

/// The sums over rows [0, n) of a set (rho and owned may be null: no density; every row its
/// own; owned: 1 for a row this rank owns, 0 for a ghost, RankExchange::owned_flags()), heights
/// measured along -g from `ref`, written to *out on ex.backend (nothing waits).
template <typename T>
void watch_sums_to(const exec::Exec& ex, const Vec3<T>* x, const Vec3<T>* v, const T* m,
                   const T* rho, const std::uint32_t* owned, std::size_t n, Vec3<T> g, Vec3<T> ref,
                   WatchSums* out, const char* label);

} // namespace kf
