// SPDX-License-Identifier: Apache-2.0
// The sketch style: setup() once when the flow opens, loop() at the requested cadence, which the
// sketch measures and reports. Rate bounds are loose (40% of the requested rate, and never
// faster than requested) so that loaded machines pass, but a wrong cadence does not.
#include <atomic>
#include <chrono>
#include <cmath>
#include <thread>

#include "sat_fixture.h"

namespace skr::sat::test {
namespace {

class Ticker : public Sketch {
 public:
  using Sketch::Sketch;
  int setups = 0;
  int loops = 0;
  int connects = 0;
  SketchStats seen;

 protected:
  void setup() override {
    ++setups;
    ASSERT_TRUE(satellite().addChannel({.name = "ticks"}));
  }
  void loop() override {
    ++loops;
    (void)satellite().publish("ticks", std::to_string(loops));
    // Stop once a whole second was measured.
    if (stats().measured_hz > 0 && loops >= 20) {
      seen = stats();
      stop();
    }
  }
  void onConnected() override { ++connects; }
};

class Sketches : public SatTest {
 protected:
  void SetUp() override { startHub(); }
};

TEST_F(Sketches, SetupOnceThenLoopAtTheRequestedCadence) {
  SketchOptions o;
  o.satellite = options("ticker");
  o.rate_hz = 50;
  o.handle_signals = false;
  Ticker t(o);
  const auto started = std::chrono::steady_clock::now();
  std::thread runner([&] { EXPECT_EQ(t.run(), 0); });
  runner.join();
  const double wall_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  EXPECT_EQ(t.setups, 1);
  EXPECT_EQ(t.connects, 1);
  EXPECT_GE(t.loops, 20);
  EXPECT_EQ(t.seen.requested_hz, 50);
  // The sketch's own measurement, and the test's clock (which includes connecting).
  EXPECT_GE(t.seen.measured_hz, 20);
  EXPECT_LE(t.seen.measured_hz, 52);
  EXPECT_GE(t.loops / wall_s, 20) << t.loops << " loops in " << wall_s << " s";
  EXPECT_LE(t.loops, 50 * wall_s + 2) << t.loops << " loops in " << wall_s << " s";
  EXPECT_TRUE(std::isfinite(t.seen.period_error_mean_ms));
  EXPECT_GE(t.seen.period_error_max_ms, t.seen.period_error_mean_ms);
  EXPECT_GE(t.seen.work_ratio_mean, 0);
  EXPECT_EQ(t.stats().loops, static_cast<uint64_t>(t.loops));
}

TEST_F(Sketches, StopFromAnotherThread) {
  SketchOptions o;
  o.satellite = options("stopped");
  o.rate_hz = 100;
  o.handle_signals = false;
  Ticker t(o);
  std::thread runner([&] { EXPECT_EQ(t.run(), 0); });
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  t.stop();
  runner.join();
}

// A sketch that follows a source: loop() runs on its pulses (the timer's 2 Hz would give a few),
// falls back to the timer when they stop (onSyncLost once), and in strict mode waits instead.
class Follower : public Sketch {
 public:
  using Sketch::Sketch;
  std::atomic<int> loops{0}, pulses{0}, lost{0};

 protected:
  void loop() override { ++loops; }
  void onSyncPulse(const SyncPulse&) override { ++pulses; }
  void onSyncLost() override { ++lost; }
};

TEST_F(Sketches, LoopFollowsASyncSourceAndFallsBackWithoutIt) {
  for (const bool strict : {false, true}) {
    SCOPED_TRACE(strict ? "strict" : "fallback");
    auto source = std::make_unique<SatOnThread>(options("source"));
    source->start();
    source->on([](Satellite& s) {
      ASSERT_TRUE(s.addChannel({.name = "clock", .kind = flow::ChannelKind::sync}));
    });
    ASSERT_TRUE(eventually([&] { return source->events.count("ready:guest.clock") == 1; }));
    SketchOptions o;
    o.satellite = options("follower");
    o.rate_hz = 20;
    o.handle_signals = false;
    o.sync_source = "guest.clock";
    o.sync_timeout_ms = 800;
    o.sync_strict = strict;
    Follower f(o);
    std::thread runner([&] { EXPECT_EQ(f.run(), 0); });
    const auto pulse = [&] {
      (void)source->on([](Satellite& s) { return s.pulse("clock"); });
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    };
    // Pulses until the follower gets one (it connects and follows meanwhile) ...
    ASSERT_TRUE(eventually([&] {
      pulse();
      return f.pulses >= 1;
    }));
    // ... then 100 at about 200 Hz: loop() runs on each (it is quick: none is dropped).
    const int first = f.pulses;
    for (int i = 0; i < 100; ++i) pulse();
    ASSERT_TRUE(eventually([&] { return f.pulses >= first + 95; })) << f.pulses;
    EXPECT_EQ(f.lost, 0);
    // Its flow database says how its loop ticks.
    auto reader = SyncClient::connect(options("reader").connection);
    ASSERT_TRUE(reader) << reader.error().message;
    ASSERT_TRUE(
        reader->selectDatabase("_flow." + std::to_string(f.satellite().login().connection_id)));
    const auto value = [&](const char* key) {
      auto v = reader->get(key);
      return v ? *v : flow::Variant();
    };
    EXPECT_EQ(value("tick_mode"), flow::Variant(strict ? "sync-strict" : "sync"));
    EXPECT_EQ(value("tick_interval_ms"), flow::Variant(50.0));
    const int during = f.loops;
    EXPECT_GE(during, f.pulses);
    EXPECT_LE(during, f.pulses + 2) << "loop() ran on the timer while pulses came";
    // No more pulses: after the timeout, loop() runs at 20 Hz again, or not at all.
    std::this_thread::sleep_for(std::chrono::milliseconds(1800));
    EXPECT_EQ(f.lost, 1);
    if (strict) {
      EXPECT_EQ(f.loops, during);
    } else {
      EXPECT_GE(f.loops - during, 5) << "the timer did not take over";
    }
    f.stop();
    runner.join();
  }
}

TEST(SketchOptionsTest, BadRobotAddressMakesRunReturnTwo) {
  ::setenv("ROBOT_ADDRESS", "carrier-pigeon:home", 1);
  Ticker t;
  ::unsetenv("ROBOT_ADDRESS");
  EXPECT_EQ(t.run(), 2);
}

}  // namespace
}  // namespace skr::sat::test
