#pragma once
// Two frames hold the same state: time, step, scalars, and every field of every phase byte for
// byte (restart and equality tests).
#include "io/Frame.hpp"

#include <gtest/gtest.h>

namespace kf::test {

inline void expect_frames_equal(const io::Frame& a, const io::Frame& b) {
  EXPECT_EQ(a.time, b.time);
  EXPECT_EQ(a.step, b.step);
  EXPECT_EQ(a.scalars, b.scalars);
  ASSERT_EQ(a.phases.size(), b.phases.size());
  for (std::size_t p = 0; p < a.phases.size(); ++p) {
    EXPECT_EQ(a.phases[p].name, b.phases[p].name);
    ASSERT_EQ(a.phases[p].fields.size(), b.phases[p].fields.size()) << a.phases[p].name;
    for (std::size_t f = 0; f < a.phases[p].fields.size(); ++f) {
      const auto& fa = a.phases[p].fields[f];
      const auto& fb = b.phases[p].fields[f];
      EXPECT_EQ(fa.name, fb.name);
      EXPECT_TRUE(fa.bytes == fb.bytes) << a.phases[p].name << "/" << fa.name << " differs";
    }
  }
}

} // namespace kf::test
