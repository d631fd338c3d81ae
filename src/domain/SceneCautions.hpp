#pragma once
// Settings a scene may ask for that are known to spoil its results, or not to buy what they are
// for: `plan` prints them and `run` prints them before it starts. Never an error: a study may
// want such a setting on purpose.
#include "domain/Scene.hpp"

#include <string>
#include <vector>

namespace kf {

/// The cubic spline's pairing instability sets in past this support [spacings]: in the sloshing
/// tank (docs/VALIDATION.md, P7) none of the particles at 2, 3% at 2.25, 61% at 2.5, 92% at 3
/// lie within half a spacing of a neighbour after 2 s; Wendland C2 (0-1.5% at supports 2-4) and
/// the spiky kernel (0.02% at 3) did not pair.
inline constexpr double kCubicPairingSupport = 2.0;

/// One line a caution, each naming the keys and what to take instead; none for a sound scene.
std::vector<std::string> scene_cautions(const Scene& scene);

} // namespace kf
