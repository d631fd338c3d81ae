#pragma once
// A triangle mesh with smooth normals drawn lit (the fluid's surface from FluidSurface), with the
// spheres' light (SphereRenderer's Lighting).
#include "render/Camera.hpp"
#include "render/FluidSurface.hpp"
#include "render/ShaderProgram.hpp"
#include "render/SphereRenderer.hpp"

#include <memory>

namespace kf::render {

/// How a mesh is drawn: one_sided, only the faces seen from their front (counter-clockwise),
/// as a plane obstacle is seen from its fluid's side and not from behind; reflective, water's
/// Fresnel reflection of the sky and the ground over its colour (opaque) or in its surface's
/// light (translucent). water: a closed mesh as translucent water into WaterLayers' front layers
/// (its front faces: their light, normal and depth) or its back faces' depth.
struct MeshLook {
  bool one_sided = false;
  bool reflective = false;
  unsigned environment = 0; // reflective: the scene's cube map (EnvironmentMap), 0: the sky's
  enum class Water { None, Front, Back } water = Water::None;
};

class MeshRenderer {
public:
  /// Needs a current context.
  MeshRenderer();
  ~MeshRenderer();
  MeshRenderer(const MeshRenderer&) = delete;
  MeshRenderer& operator=(const MeshRenderer&) = delete;

  /// Moves the mesh to the GPU: the draws after it show it (a frame's passes, the shadow maps'
  /// and the picture's, share one upload: a garment's yarns are hundreds of MB).
  void upload(const SurfaceMesh& mesh);
  /// Draws, instead, another's GL buffers: vertices in upload's layout (position, normal, shade:
  /// 7 floats) and `indices` indices, three a triangle (SurfaceCompute's surface).
  void show(unsigned vertex_buffer, unsigned index_buffer, std::size_t indices);
  /// Draws the last uploaded mesh into the bound target with depth testing, opaque, in
  /// `colour`.
  void draw(const glm::vec4& colour, const ViewMatrices& view, const Lighting& light = {},
            MeshLook look = {});
  void draw(const SurfaceMesh& mesh, const glm::vec4& colour, const Camera& camera, double aspect,
            const Lighting& light = {}) {
    upload(mesh);
    draw(colour, ViewMatrices::of(camera, aspect), light);
  }

private:
  std::unique_ptr<ShaderProgram> program_, water_program_, depth_program_;
  unsigned vao_ = 0, vertices_ = 0, indices_ = 0;
  std::size_t vertex_capacity_ = 0, index_capacity_ = 0, indices_drawn_ = 0;
};

} // namespace kf::render
