// The sketch style: setup() once when the flow opens, loop() at the requested cadence, which the
// sketch measures and reports. Rate bounds are loose (40% of the requested rate, and never
// faster than requested) so that loaded machines pass, but a wrong cadence does not.
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

TEST(SketchOptionsTest, BadRobotAddressMakesRunReturnTwo) {
  ::setenv("ROBOT_ADDRESS", "carrier-pigeon:home", 1);
  Ticker t;
  ::unsetenv("ROBOT_ADDRESS");
  EXPECT_EQ(t.run(), 2);
}

}  // namespace
}  // namespace skr::sat::test
