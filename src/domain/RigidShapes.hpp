#pragma once
#include "domain/Scene.hpp"
#include "kernels/boundary/RigidShape.hpp"

#include <vector>

namespace kf {

/// The scene's solids as signed-distance shapes: obstacle i at index i, then the domain container
/// (its closed walls) last when any wall is closed.
template <typename T>
std::vector<RigidShape<T>> make_rigid_shapes(const Scene& scene);

} // namespace kf
