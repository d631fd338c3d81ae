// `--frames A:B:S` (render/FrameSelection): the frames chosen among those a run wrote, and bad
// specs refused with a message that names them; the film's one camera (SnapshotRenderer's
// film_camera) keeps its first and last frames in the picture.
#include "core/Error.hpp"
#include "render/FrameSelection.hpp"
#include "render/SnapshotRender.hpp"

#include <gtest/gtest.h>

#include <cmath>

using kf::render::select_frames;
using V = std::vector<std::uint64_t>;

TEST(RenderFrames, SelectsByFirstLastAndStep) {
  const V all{0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10};
  EXPECT_EQ(select_frames("::", all), all);
  EXPECT_EQ(select_frames("", all), all);
  EXPECT_EQ(select_frames("3", all), (V{3}));
  EXPECT_EQ(select_frames("3:", all), (V{3, 4, 5, 6, 7, 8, 9, 10}));
  EXPECT_EQ(select_frames(":3", all), (V{0, 1, 2, 3}));
  EXPECT_EQ(select_frames("2:9:3", all), (V{2, 5, 8}));
  EXPECT_EQ(select_frames("::4", all), (V{0, 4, 8}));
  EXPECT_EQ(select_frames(" 1 : 4 ", all), (V{1, 2, 3, 4}));
  // Among the frames that exist (a run restarted, or some deleted): the step counts from A.
  EXPECT_EQ(select_frames("0:20:2", V{1, 2, 4, 5, 6, 9, 12}), (V{2, 4, 6, 12}));
  EXPECT_EQ(select_frames("11:", all), V{});
  EXPECT_EQ(select_frames("::", V{}), V{});
}

TEST(RenderFrames, RefusesMalformedSpecsByName) {
  const V all{0, 1, 2};
  for (const char* bad : {"a:b", "1:2:3:4", "-1:", "1.5", "::0", "99999999999999999999999:"}) {
    try {
      select_frames(bad, all);
      ADD_FAILURE() << "'" << bad << "' was accepted";
    } catch (const kf::InputError& e) {
      EXPECT_NE(std::string(e.what()).find(std::string("--frames '") + bad + "'"),
                std::string::npos)
          << e.what();
    }
  }
}

namespace {

/// Fluid points 1 cm apart filling the box lo .. hi.
kf::io::Frame fluid_block(glm::dvec3 lo, glm::dvec3 hi) {
  std::vector<float> x;
  for (double px = lo.x; px <= hi.x; px += 0.01)
    for (double py = lo.y; py <= hi.y; py += 0.01)
      for (double pz = lo.z; pz <= hi.z; pz += 0.01)
        x.insert(x.end(), {float(px), float(py), float(pz)});
  kf::io::Frame f;
  f.phases.push_back({"fluid", {kf::io::Field::from("position", x, 3)}});
  return f;
}

/// Whether the box's 8 corners project inside the picture.
bool in_view(const kf::render::Camera& cam, double aspect,
             const std::pair<glm::dvec3, glm::dvec3>& box) {
  const glm::dmat4 m = glm::dmat4(cam.projection(aspect)) * glm::dmat4(cam.view());
  for (int c = 0; c < 8; ++c) {
    const auto& [lo, hi] = box;
    const glm::dvec4 p =
        m * glm::dvec4(c & 1 ? hi.x : lo.x, c & 2 ? hi.y : lo.y, c & 4 ? hi.z : lo.z, 1.0);
    if (p.w <= 0 || std::abs(p.x / p.w) > 1 || std::abs(p.y / p.w) > 1)
      return false;
  }
  return true;
}

} // namespace

// A dam break's column spreads over its tank: the first frame's camera loses the spread water
// (the default scene's pictures did), the film's keeps both frames whole.
TEST(RenderFrames, TheFilmsCameraKeepsTheFirstAndTheLastFrameInView) {
  kf::render::SnapshotStyle style;
  style.width = 320;
  style.height = 180;
  const double aspect = double(style.width) / style.height;
  kf::render::SnapshotRenderer r(style);
  const kf::io::Frame column = fluid_block({0, 0, 0}, {0.2, 0.2, 0.4});
  const kf::io::Frame spread = fluid_block({0, 0, 0}, {0.8, 0.2, 0.08});
  ASSERT_FALSE(in_view(r.frame_camera(column), aspect, r.frame_box(spread)))
      << "the spread water fits the column's camera: the case shows nothing";
  const kf::render::Camera film = r.film_camera(column, spread);
  EXPECT_TRUE(in_view(film, aspect, r.frame_box(column)));
  EXPECT_TRUE(in_view(film, aspect, r.frame_box(spread)));
  // The tank a fluid is walled in, where given: its lid too (the run-up between the frames).
  const std::pair<glm::dvec3, glm::dvec3> tank{{0, 0, 0}, {0.8, 0.2, 0.6}};
  ASSERT_FALSE(in_view(film, aspect, tank)) << "the tank fits the frames' camera: nothing shown";
  EXPECT_TRUE(in_view(r.film_camera(column, spread, tank), aspect, tank));
  // A last frame with nothing to draw adds nothing: the first frame's framing.
  const kf::render::Camera alone = r.film_camera(column, kf::io::Frame{});
  const kf::render::Camera first = r.frame_camera(column);
  EXPECT_EQ(alone.eye, first.eye);
  EXPECT_EQ(alone.target, first.target);
}
