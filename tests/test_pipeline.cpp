// The pipeline's stage timings on the device's clock (Pipeline::time_on_device), checked on the
// CPU backend, where a stage's work is done when its call returns: each stage's span is its own
// work, and the time between runs (the host elsewhere: the device would wait) goes to the wait
// before the first stage, not to another stage.
#include "core/Error.hpp"
#include "domain/Pipeline.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <thread>

using namespace kf;

namespace {

void sleep_ms(int ms) {
  std::this_thread::sleep_for(std::chrono::milliseconds(ms));
}

} // namespace

TEST(Pipeline, DeviceTimesPlaceEachSpanAndTheWaitBeforeIt) {
  Pipeline p;
  p.add("a", "m", "", [] { sleep_ms(20); });
  p.add("b", "m", "", [] { sleep_ms(5); });
  p.time_on_device(exec::Backend::Cpu);
  const int runs = 4;
  for (int r = 0; r < runs; ++r) {
    if (r > 0)
      sleep_ms(10); // between steps: before stage a
    p.run();
  }
  p.collect_device();
  const auto& a = p.stages()[0];
  const auto& b = p.stages()[1];
  // A sleep lasts at least its time and overruns by scheduling only: lower bounds are exact,
  // and the upper ones leave a loaded 2-core machine a sleep's length of slack.
  EXPECT_GE(a.device_seconds, runs * 0.020);
  EXPECT_GE(b.device_seconds, runs * 0.005);
  EXPECT_LT(b.device_seconds, a.device_seconds);
  EXPECT_GE(a.idle_before_seconds, (runs - 1) * 0.010); // no wait before the first run
  EXPECT_LT(a.idle_before_seconds, a.device_seconds);
  EXPECT_LT(b.idle_before_seconds, 0.010); // stage b follows a at once
}

TEST(Pipeline, AStageThatThrowsLeavesTheTimersPaired) {
  Pipeline p;
  bool fail = true;
  p.add("a", "m", "", [] {});
  p.add("b", "m", "", [&] {
    if (fail)
      throw Error("device failure");
  });
  p.time_on_device(exec::Backend::Cpu);
  EXPECT_THROW(p.run(), Error);
  fail = false;
  EXPECT_NO_THROW(p.run()); // a watchdog's rollback runs the pipeline again
  EXPECT_NO_THROW(p.collect_device());
  EXPECT_EQ(p.stages()[0].calls, 2u);
  EXPECT_EQ(p.stages()[1].calls, 1u);
}
