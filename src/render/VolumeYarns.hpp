#pragma once
// The knit's yarns drawn volumetrically (paper §6, after Xu et al.'s lumislice): every drawn
// segment of the yarns (TubeRenderer's frames on the GPU: centre and radius, r and shade, b and
// arc length) is cut by a few parallel quads of the stack facing the eye (yarn_slices.comp);
// the quads' distances are sorted (DepthSort: CUB on the GPU's own buffers, the host's radix
// sort under llvmpipe) and they are drawn back to front, each shaded from the lumislice turned
// by the yarn's twist and blended "over" what is behind (premultiplied). The yarns' depth (a
// core the fibres nearly hide) is the tubes', drawn after: VolumeYarns leaves the depth buffer
// as it found it.
#include "render/DepthSort.hpp"
#include "render/Lighting.hpp"
#include "render/Lumislice.hpp"
#include "render/ShaderProgram.hpp"

#include <glm/glm.hpp>

#include <vector>

namespace kf::render {

class TubeRenderer;

class VolumeYarns {
public:
  /// Needs a current context; computes the lumislice and moves it to a texture. sort_on_cuda:
  /// DepthSort's.
  VolumeYarns(const LumisliceSpec& spec, bool sort_on_cuda, int slices = 4);
  ~VolumeYarns();
  VolumeYarns(const VolumeYarns&) = delete;
  VolumeYarns& operator=(const VolumeYarns&) = delete;

  /// The slices of `tubes`' drawn segments for the eye of `view`, keyed and sorted (send before
  /// draw: the sort is its own pass), and the light reaching each segment (light's shadows).
  /// radius: the dry yarn's [m], which sets the twist's pitch.
  void order(const TubeRenderer& tubes, const ViewMatrices& view, double radius,
             const Lighting& light = {});
  /// The ordered slices drawn into the bound target: depth tested, not written; blended.
  void draw(const TubeRenderer& tubes, const glm::vec4& colour, const ViewMatrices& view,
            const Lighting& light);
  std::size_t quads() const { return quads_; }
  /// The last order's distances from the eye in the order drawn (tests: back to front).
  std::vector<float> drawn_distances() const;
  const Lumislice& lumislice() const { return slice_; }
  bool sorts_on_cuda() const { return sort_.on_cuda(); }

private:
  Lumislice slice_;
  int slices_;
  ShaderProgram program_, order_program_;
  DepthSort sort_;
  unsigned texture_ = 0, vao_ = 0;
  unsigned buffers_[3] = {0, 0, 0}; // keys, codes, the light a segment
  std::size_t capacity_[3] = {0, 0, 0};
  std::size_t quads_ = 0;
  float twist_ = 0;
};

} // namespace kf::render
