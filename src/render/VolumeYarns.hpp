#pragma once
// The knit's yarns drawn volumetrically (paper §6, after Xu et al.'s lumislice): every drawn
// segment of the yarns (TubeRenderer's frames on the GPU: centre and radius, r and shade, b and
// arc length) is cut by a few parallel quads of the stack facing the eye (yarn_slices.comp);
// where the yarn is small on screen (the level of detail: detail_pixels) a piece of it, short
// straight runs of segments merged, is one quad facing the eye, shaded from the lumislice seen
// whole along the line of sight. The quads' distances are sorted (DepthSort: CUB on the GPU's own
// buffers, the host's radix sort under llvmpipe) and they are drawn back to front, each shaded from
// the lumislice turned by the yarn's twist and blended "over" what is behind (premultiplied). The
// yarns' depth (a core the fibres nearly hide) is the tubes', drawn after: VolumeYarns leaves the
// depth buffer as it found it.
#include "render/DepthSort.hpp"
#include "render/Lighting.hpp"
#include "render/Lumislice.hpp"
#include "render/ShaderProgram.hpp"
#include "render/SpaceSplit.hpp"

#include <glm/glm.hpp>

#include <vector>

namespace kf::render {

class TubeRenderer;

class VolumeYarns {
public:
  /// Needs a current context; computes the lumislice and moves it to a texture. sort_on_cuda:
  /// DepthSort's. slices: a segment's; detail_pixels > 0: a piece of yarn under that size on
  /// screen is one quad seen whole, short straight runs of segments merged (0: every segment
  /// its `slices`).
  VolumeYarns(const LumisliceSpec& spec, bool sort_on_cuda, int slices = 4,
              double detail_pixels = 0);
  ~VolumeYarns();
  VolumeYarns(const VolumeYarns&) = delete;
  VolumeYarns& operator=(const VolumeYarns&) = delete;

  /// The slices of `tubes`' drawn segments for the eye of `view`, keyed and sorted (send before
  /// draw: the sort is its own pass), and the light reaching each segment (light's shadows).
  /// radius: the dry yarn's [m], which sets the twist's pitch. height: the picture's [pixels],
  /// for the level of detail (0: none).
  void order(const TubeRenderer& tubes, const ViewMatrices& view, double radius,
             const Lighting& light = {}, int height = 0);
  /// The ordered slices drawn into the bound target: depth tested, not written; blended; with
  /// `clip`, cut at its faces (a sort-last part's, RegionClip).
  void draw(const TubeRenderer& tubes, const glm::vec4& colour, const ViewMatrices& view,
            const Lighting& light, const Region* clip = nullptr);
  /// The quads the last order draws (read back: a wait for the GPU).
  std::size_t drawn_quads() const;
  /// The last order's distances from the eye in the order drawn (tests: back to front).
  std::vector<float> drawn_distances() const;
  const Lumislice& lumislice() const { return slice_; }
  bool sorts_on_cuda() const { return sort_.on_cuda(); }

private:
  /// The shaders' buffers: the tubes' frames (0-3), keys, slots, pieces, light (8-11), the
  /// indirect draw (12), the points' colours where the tubes have them (13).
  void bind(const TubeRenderer& tubes) const;
  Lumislice slice_;
  int slices_;
  double detail_pixels_;
  ShaderProgram program_, order_program_;
  DepthSort sort_;
  unsigned texture_ = 0, seen_texture_ = 0, vao_ = 0;
  unsigned buffers_[4] = {0, 0, 0, 0}; // keys, slots, pieces, the light a piece
  std::size_t capacity_[4] = {0, 0, 0, 0};
  unsigned draw_ = 0;     // the indirect draw's command: its vertex count from yarn_slices.comp
  std::size_t slots_ = 0; // segments x slices: keys sorted (the unused last)
  float twist_ = 0;
};

} // namespace kf::render
