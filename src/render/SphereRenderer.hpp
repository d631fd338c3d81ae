#pragma once
// Spheres drawn as ray-cast impostors: one camera-facing quad a sphere, the exact silhouette,
// depth and normal per pixel from a ray against it (no tessellation, millions a frame). The
// preview look of particles (P6 stage 2), and the obstacles' spheres.
#include "render/Camera.hpp"
#include "render/Lighting.hpp"
#include "render/ShaderProgram.hpp"

#include <glm/glm.hpp>

#include <memory>
#include <vector>

namespace kf::render {

struct Sphere {
  glm::vec4 centre_radius; // x, y, z, radius
  glm::vec4 colour;        // linear RGB, alpha (1: opaque)
};

class SphereRenderer {
public:
  /// Needs a current context.
  SphereRenderer();
  ~SphereRenderer();
  SphereRenderer(const SphereRenderer&) = delete;
  SphereRenderer& operator=(const SphereRenderer&) = delete;

  /// Moves the spheres to the GPU: the draws after it show them (a frame's passes share it).
  void upload(const std::vector<Sphere>& spheres);
  /// Draws the last uploaded spheres into the bound target with depth testing, lit by `light`.
  void draw(const ViewMatrices& view, const Lighting& light = {});
  void draw(const std::vector<Sphere>& spheres, const ViewMatrices& view,
            const Lighting& light = {}) {
    upload(spheres);
    draw(view, light);
  }
  void draw(const std::vector<Sphere>& spheres, const Camera& camera, double aspect,
            const Lighting& light = {}) {
    draw(spheres, ViewMatrices::of(camera, aspect), light);
  }

private:
  std::unique_ptr<ShaderProgram> program_;
  unsigned vao_ = 0, buffer_ = 0;
  std::size_t capacity_ = 0, count_ = 0;
};

} // namespace kf::render
