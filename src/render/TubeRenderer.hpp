#pragma once
// The yarns' tubes drawn from their points' frames (YarnFrames): the rings are built in the
// vertex shader (shaders/tube.vert) and the index list by a compute pass (tube_indices.comp),
// so a frame moves 52 bytes a yarn point to the GPU instead of a mesh's 8 vertices and 48
// indices (about 400 bytes), and no host builds them. Lit as MeshRenderer's meshes (mesh.frag).
#include "render/Camera.hpp"
#include "render/Lighting.hpp"
#include "render/ShaderProgram.hpp"
#include "render/YarnTubes.hpp"

#include <glm/glm.hpp>

#include <memory>

namespace kf::render {

class TubeRenderer {
public:
  /// Needs a current context.
  TubeRenderer();
  ~TubeRenderer();
  TubeRenderer(const TubeRenderer&) = delete;
  TubeRenderer& operator=(const TubeRenderer&) = delete;

  /// No tubes: the draws after it draw nothing.
  void clear() { segments_ = 0; }
  /// Moves the frames to the GPU: the draws after it show their tubes of `sides` sides.
  void upload(const YarnFrames& frames, int sides);
  /// The same from the yarns themselves: their chains listed on the host (yarn_chains), the
  /// frames computed on the GPU (shaders/yarn_frames.comp, a yarn a thread), so the host moves
  /// 16 bytes a point.
  /// `only` and `reach` choose the drawn segments (yarn_chains').
  void build(const YarnPoints& yarns, const YarnStyle& style, const Region* only = nullptr,
             double reach = 0);
  /// Draws the last uploaded tubes into the bound target with depth testing, in `colour`
  /// scaled by each point's shade; coarse, with every other ring vertex (half the sides, an even
  /// number of them: for shadow maps); one_sided, the faces turned away culled (seen from
  /// outside, a tube's own front faces hide them; only a yarn's open end shows the difference);
  /// with `clip`, cut at its faces (RegionClip).
  void draw(const glm::vec4& colour, const ViewMatrices& view, const Lighting& light = {},
            bool coarse = false, bool one_sided = false, const Region* clip = nullptr);
  std::size_t triangles() const { return segments_ * 2 * std::size_t(sides_); }
  /// The drawn segments and the buffers the tubes are built from (VolumeYarns slices the same
  /// yarns): 0 centre and radius, 1 r and shade, 2 b and the arc length from the yarn's start
  /// (vec4 a point), 3 the drawn segments' first points (uint).
  std::size_t segments() const { return segments_; }
  unsigned frame_buffer(int i) const { return buffers_[i]; }
  /// The points' stitch colours (vec4 a point, a > 0 where given; build's), or 0 for none.
  unsigned colour_buffer() const { return coloured_ ? buffers_[8] : 0u; }

private:
  std::unique_ptr<ShaderProgram> program_;
  ShaderProgram index_program_, frame_program_;
  /// The index lists of the drawn segments (buffers_[3]) for `sides`.
  void make_indices(int sides);
  unsigned vao_ = 0;
  // centre_radius, r_shade, b, drawn; the indices, all sides and every other; the points and
  // the chains (build)
  // centre_radius, r_shade, b, drawn; the indices, all sides and every other; the points and
  // the chains (build); the points' colours (build, where the yarns carry them)
  unsigned buffers_[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};
  std::size_t capacity_[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};
  bool coloured_ = false;
  std::size_t segments_ = 0;
  int sides_ = 0;
};

} // namespace kf::render
