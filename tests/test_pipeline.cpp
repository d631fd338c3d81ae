// The pipeline's stage timings on the device's clock (Pipeline::time_on_device), checked on the
// CPU backend, where a stage's work is done when its call returns: each stage's span is its own
// work, and the time between runs (the host elsewhere: the device would wait) goes to the wait
// before the first stage, not to another stage.
#include "core/Error.hpp"
#include "domain/Pipeline.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <string>
#include <thread>
#include <vector>

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

// The step's size (P10 stage 11): the stages marked before_dt run before it is settled, and it is
// settled before the first stage that is not, whatever the stages' order after that.
TEST(Pipeline, StagesBeforeTheStepSizeRunBeforeItIsSettled) {
  Pipeline p;
  std::vector<std::string> seen;
  bool settled = false;
  p.add(
      "absorb", "m", "", [&] { seen.push_back(settled ? "absorb late" : "absorb"); }, true);
  p.add(
      "begin", "m", "", [&] { seen.push_back(settled ? "begin late" : "begin"); }, true);
  p.add("knit", "m", "", [&] { seen.push_back(settled ? "knit" : "knit without dt"); });
  p.add("fluid", "m", "", [&] { seen.push_back(settled ? "fluid" : "fluid without dt"); });
  const auto settle = [&] {
    if (!settled)
      seen.push_back("settle");
    settled = true;
  };
  p.run({}, settle);
  EXPECT_EQ(seen, (std::vector<std::string>{"absorb", "begin", "settle", "knit", "fluid"}));
  // Without a settle hook (a size known before the run) every stage simply runs.
  seen.clear();
  p.run();
  EXPECT_EQ(seen, (std::vector<std::string>{"absorb late", "begin late", "knit", "fluid"}));
}
