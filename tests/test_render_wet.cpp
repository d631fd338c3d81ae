// The wet knit's darkening measured on the picture (P6, paper §6): the mean luminance of a knit
// patch at saturation s over the same patch dry is 1 - alpha sqrt(s), alpha = 0.15, within 2%.
#include "render/SnapshotRender.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

using namespace kf;

namespace {

/// A flat patch of knit points (one layer, 2 mm apart) at saturation s.
io::Frame patch(float s) {
  std::vector<float> x, sat;
  for (int i = 0; i < 80; ++i)
    for (int j = 0; j < 80; ++j) {
      x.insert(x.end(), {0.002f * float(i), 0.002f * float(j), 0.0f});
      sat.push_back(s);
    }
  io::Frame f;
  f.phases.push_back(
      {"knit", {io::Field::from("position", x, 3), io::Field::from("saturation", sat, 1)}});
  return f;
}

/// Mean Rec. 709 luminance of the pixels the patch covers (depth < 1), and how many there are.
std::pair<double, std::size_t> patch_luminance(render::SnapshotRenderer& r, const io::Frame& f,
                                               const render::Camera& cam) {
  const io::RgbaImage img = r.draw(f, cam);
  const std::vector<float> depth = r.depth();
  double sum = 0;
  std::size_t n = 0;
  for (std::size_t k = 0; k < depth.size(); ++k)
    if (depth[k] < 1.0f) {
      const std::uint8_t* p = &img.pixels[4 * k];
      sum += 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2];
      ++n;
    }
  return {n ? sum / double(n) : 0.0, n};
}

} // namespace

TEST(RenderWet, PatchLuminanceFallsAsOneMinusAlphaRootS) {
  for (float highlights : {0.0f, 0.25f}) {
    render::SnapshotStyle style;
    style.width = 320;
    style.height = 240;
    style.lighting.specular = highlights;
    render::SnapshotRenderer r(style);
    const io::Frame dry = patch(0.0f);
    const render::Camera cam = r.frame_camera(dry);
    const auto [l0, n0] = patch_luminance(r, dry, cam);
    ASSERT_GT(n0, 320u * 240u / 10) << "the patch covers too little of the picture to measure";
    for (float s : {0.1f, 0.25f, 0.5f, 1.0f}) {
      const auto [l, n] = patch_luminance(r, patch(s), cam);
      EXPECT_EQ(n, n0) << "the wet patch covers other pixels";
      const double want = 1 - style.wet_darkening * std::sqrt(double(s));
      // The darkening scales the yarn's albedo (ambient and diffuse); the white highlights
      // (not darkened: the light's colour) lift the ratio by 0.2-0.75% (s = 0.1-1, measured on
      // llvmpipe). The bound is 2%.
      EXPECT_NEAR(l / l0, want, 0.02 * want)
          << "s = " << s << ", highlights " << highlights << ": " << l << " against " << l0;
      if (highlights == 0.0f) { // albedo alone: 8-bit rounding averaged over the patch
        EXPECT_NEAR(l / l0, want, 0.001) << "s = " << s; // (measured within 1e-4)
      }
      std::printf("highlights %.2f, s = %.2f: luminance ratio %.4f, 1 - 0.15 sqrt(s) = %.4f\n",
                  highlights, s, l / l0, want);
    }
  }
}
