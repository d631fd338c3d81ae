#pragma once
// A triangle mesh with smooth normals drawn lit (the fluid's surface from FluidSurface), with the
// spheres' light (SphereRenderer's Lighting).
#include "render/Camera.hpp"
#include "render/FluidSurface.hpp"
#include "render/ShaderProgram.hpp"
#include "render/SphereRenderer.hpp"

#include <memory>

namespace kf::render {

class MeshRenderer {
public:
  /// Needs a current context.
  MeshRenderer();
  ~MeshRenderer();
  MeshRenderer(const MeshRenderer&) = delete;
  MeshRenderer& operator=(const MeshRenderer&) = delete;

  /// Draws the mesh into the bound target with depth testing, opaque, in `colour`.
  void draw(const SurfaceMesh& mesh, const glm::vec4& colour, const Camera& camera, double aspect,
            const Lighting& light = {});

private:
  std::unique_ptr<ShaderProgram> program_;
  unsigned vao_ = 0, vertices_ = 0, indices_ = 0;
  std::size_t vertex_capacity_ = 0, index_capacity_ = 0;
};

} // namespace kf::render
