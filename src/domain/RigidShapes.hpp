#pragma once
#include "domain/Scene.hpp"
#include "kernels/boundary/RigidShape.hpp"
#include "kernels/exec/DeviceBuffer.hpp"

#include <vector>

namespace kf {

/// The scene's solids as signed-distance shapes: obstacle i at index i, then the domain container
/// (its closed walls) last when any wall is closed. Owns the sampled signed distances of mesh
/// obstacles on `backend`: the table's `sdf` pointers point into them, so the table may be used
/// (copied to that backend, passed to kernels) only while this object lives. Moving it keeps the
/// pointers valid.
template <typename T>
class RigidShapes {
public:
  explicit RigidShapes(const Scene& scene, exec::Backend backend = exec::Backend::Cpu);

  /// Host copy of the table (offsets may be updated here, then copied to the device).
  std::vector<RigidShape<T>>& table() { return table_; }
  const std::vector<RigidShape<T>>& table() const { return table_; }
  bool empty() const { return table_.empty(); }
  /// Memory of the sampled signed distances on the backend.
  std::size_t bytes() const;

private:
  std::vector<RigidShape<T>> table_;
  std::vector<exec::DeviceBuffer<T>> grids_;
};

} // namespace kf
