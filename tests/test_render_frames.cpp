// `--frames A:B:S` (render/FrameSelection): the frames chosen among those a run wrote, and bad
// specs refused with a message that names them.
#include "core/Error.hpp"
#include "render/FrameSelection.hpp"

#include <gtest/gtest.h>

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
