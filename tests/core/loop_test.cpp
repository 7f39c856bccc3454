// SPDX-License-Identifier: Apache-2.0
#include "test_support.h"

#include <skrobot/runtime/loop.h>

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <thread>
#include <vector>

namespace skr {
namespace {

constexpr Nanos kLongTimeout = 20 * kNsPerSec;  // generous: tests must not fail on slow machines

LoopOptions options(TimingMode mode, Nanos fast_ms, Nanos slow_ms) {
  LoopOptions o;
  o.mode = mode;
  o.fast_interval_ns = fast_ms * kNsPerMs;
  o.slow_interval_ns = slow_ms * kNsPerMs;
  return o;
}

// addTickHandler is loop-thread only: once the loop runs on its thread, a call from another
// thread aborts with a line naming the call, in every build.
TEST(LoopDeathTest, AddTickHandlerFromAnotherThreadAborts) {
  ::testing::GTEST_FLAG(death_test_style) = "threadsafe";
  EXPECT_DEATH(
      {
        LoopThread t(LoopOptions{.name = "bound"});
        t.start();
        (void)t.loop().addTickHandler(Tick::fast, [] {});
      },
      "Loop::addTickHandler called off loop 'bound''s thread");
  // Before the loop is bound to a thread, any thread may add handlers.
  Loop loop;
  std::thread other([&] { (void)loop.addTickHandler(Tick::fast, [] {}); });
  other.join();
}

TEST(TimingMode, NamesRoundTrip) {
  for (auto m : {TimingMode::coarse, TimingMode::pseudo_realtime, TimingMode::socket_driven,
                 TimingMode::none}) {
    TimingMode parsed{};
    ASSERT_TRUE(parseTimingMode(timingModeName(m), parsed));
    EXPECT_EQ(parsed, m);
  }
  TimingMode ignored{};
  EXPECT_FALSE(parseTimingMode("fast", ignored));
}

// Every timing mode that waits must never tick faster than its nominal rate: deadlines are
// absolute, missed ones are skipped, and a second holds at most 1 s / interval fast ticks.
class TickModes : public ::testing::TestWithParam<TimingMode> {};

TEST_P(TickModes, TicksComeInOrderAtTheNominalRate) {
  Loop loop(options(GetParam(), 10, 50));
  std::vector<char> seq;
  loop.addTickHandler(Tick::fast, [&] { seq.push_back('f'); });
  loop.addTickHandler(Tick::slow, [&] { seq.push_back('s'); });
  loop.addTickHandler(Tick::one_sec, [&] { seq.push_back('1'); });
  ASSERT_TRUE(loop.runUntil([&] { return loop.stats().one_sec_ticks >= 1; }, kLongTimeout));

  const auto& st = loop.stats();
  EXPECT_GE(st.fast_ticks, st.slow_ticks);
  EXPECT_GE(st.slow_ticks, st.one_sec_ticks);
  EXPECT_LE(st.fast_ticks, 101u);  // 1 s / 10 ms, plus the tick that carries OneSecTick
  EXPECT_LE(st.slow_ticks, 21u);
  // ... and not much slower either: a loop that ticks late (or once a second) fails here. The
  // bounds are loose (30% of nominal) for loaded machines.
  EXPECT_GE(st.fast_ticks, 30u);
  EXPECT_GE(st.slow_ticks, 6u);
  EXPECT_EQ(st.one_sec_ticks, 1u);
  // Slow and one-second ticks run right after the fast tick of the same pulse.
  ASSERT_FALSE(seq.empty());
  EXPECT_EQ(seq.front(), 'f');
  for (size_t i = 1; i < seq.size(); ++i) {
    if (seq[i] == 's') {
      EXPECT_EQ(seq[i - 1], 'f');
    }
    if (seq[i] == '1') {
      EXPECT_TRUE(seq[i - 1] == 'f' || seq[i - 1] == 's');
    }
  }
  EXPECT_GT(st.fast_rate_hz, 0.0);
}

INSTANTIATE_TEST_SUITE_P(Waiting, TickModes,
                         ::testing::Values(TimingMode::coarse, TimingMode::pseudo_realtime,
                                           TimingMode::socket_driven));

TEST(Loop, NoneModeTicksBackToBack) {
  // A 1 s fast interval would give ~5 ticks in 5 s; "none" must not wait at all.
  Loop loop(options(TimingMode::none, 1000, 1000));
  ASSERT_TRUE(loop.runUntil([&] { return loop.stats().fast_ticks >= 1000; }, kLongTimeout));
}

TEST(Loop, SocketDrivenTicksEarlyOnIo) {
  // The fast interval (10 s) is only the longest wait: each wake-up from other threads ticks.
  Loop loop(options(TimingMode::socket_driven, 10'000, 10'000));
  std::atomic<bool> stop{false};
  std::thread poster([&] {
    while (!stop) {
      loop.post([] {});
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
  });
  const bool ok = loop.runUntil([&] { return loop.stats().fast_ticks >= 5; }, 8 * kNsPerSec);
  stop = true;
  poster.join();
  EXPECT_TRUE(ok);
}

TEST(Loop, BusyPollingAfterActivityThenSleepingAgain) {
  // Socket-driven ticks come with every loop iteration, so they show whether the loop sleeps:
  // the 10 s interval would allow one tick; busy polling gives thousands.
  LoopOptions o = options(TimingMode::socket_driven, 10'000, 10'000);
  o.busy_poll_ns = 300 * kNsPerMs;
  Loop loop(o);
  loop.post([&] { loop.noteActivity(); });
  ASSERT_TRUE(loop.runUntil([&] { return loop.stats().fast_ticks >= 1000; }, kLongTimeout));
  // Without further activity it goes back to sleep within busy_poll_ns.
  loop.runFor(1500 * kNsPerMs);
  const auto before = loop.stats().fast_ticks;
  loop.runFor(1000 * kNsPerMs);
  EXPECT_LE(loop.stats().fast_ticks - before, 2u);  // runFor's own time-limit wake-up ticks
}

TEST(Loop, NoBusyPollingByDefault) {
  Loop loop(options(TimingMode::socket_driven, 10'000, 10'000));
  loop.post([&] { loop.noteActivity(); });
  loop.runFor(300 * kNsPerMs);
  EXPECT_LT(loop.stats().fast_ticks, 10u);
}

TEST(Loop, PostFromManyThreadsRunsEverythingInOrderPerThread) {
  Loop loop;
  constexpr int kThreads = 4;
  constexpr int kPerThread = 2000;
  std::vector<std::vector<int>> seen(kThreads);
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&, t] {
      for (int i = 0; i < kPerThread; ++i) loop.post([&seen, t, i] { seen[t].push_back(i); });
    });
  }
  const auto total = [&] {
    size_t n = 0;
    for (auto& s : seen) n += s.size();
    return n;
  };
  ASSERT_TRUE(loop.runUntil([&] { return total() == kThreads * kPerThread; }, kLongTimeout));
  for (auto& th : threads) th.join();
  for (auto& s : seen) {
    for (int i = 0; i < kPerThread; ++i) ASSERT_EQ(s[i], i);
  }
  EXPECT_EQ(loop.stats().posted, static_cast<uint64_t>(kThreads * kPerThread));
}

// A batch of long posted work does not hold the loop: after the pulse's budget the rest waits for
// the next iteration, so ticks (and I/O) run between the jobs, which keep their order.
TEST(Loop, LongPostedWorkLetsTicksRunBetweenJobs) {
  Loop loop(options(TimingMode::coarse, 1, 100));
  std::vector<char> seq;
  std::vector<int> order;
  loop.addTickHandler(Tick::fast, [&] { seq.push_back('t'); });
  for (int i = 0; i < 20; ++i) {
    loop.post([&, i] {
      const Nanos until = monotonicNs() + 2 * kNsPerMs;
      while (monotonicNs() < until) {
      }
      seq.push_back('j');
      order.push_back(i);
    });
  }
  ASSERT_TRUE(loop.runUntil([&] { return order.size() == 20; }, kLongTimeout));
  for (int i = 0; i < 20; ++i) ASSERT_EQ(order[i], i);
  const std::string s(seq.begin(), seq.end());
  const auto first = s.find('j'), last = s.rfind('j');
  EXPECT_NE(s.substr(first, last - first).find('t'), std::string::npos)
      << "no tick ran during 40 ms of posted work: " << s;
}

TEST(Loop, PostedWorkRunsAtNextPulseNotInline) {
  Loop loop;
  bool ran = false;
  loop.post([&] { ran = true; });
  EXPECT_FALSE(ran);
  test::pump(loop);
  EXPECT_TRUE(ran);
}

TEST(Loop, TickHandlerAddedDuringTickRunsFromNextOneAndRemovedNeverRuns) {
  Loop loop(options(TimingMode::coarse, 1, 10));
  int first = 0;
  int added = 0;
  int removed = 0;
  TickId removed_id = loop.addTickHandler(Tick::fast, [&] { ++removed; });
  loop.addTickHandler(Tick::fast, [&] {
    if (++first == 1) {
      loop.addTickHandler(Tick::fast, [&] { ++added; });
      loop.removeTickHandler(removed_id);
    }
  });
  ASSERT_TRUE(loop.runUntil([&] { return first >= 5; }, kLongTimeout));
  EXPECT_EQ(removed, 1);        // ran before its removal in the same tick
  EXPECT_EQ(added, first - 1);  // not in the tick that added it
}

TEST(Loop, ThrowingHandlerIsLoggedAndTheLoopGoesOn) {
  test::LogCapture logs;
  Loop loop(options(TimingMode::coarse, 1, 10));
  int after = 0;
  loop.addTickHandler(Tick::fast, [] { throw std::runtime_error("boom"); });
  loop.addTickHandler(Tick::fast, [&] { ++after; });
  ASSERT_TRUE(loop.runUntil([&] { return after >= 3; }, kLongTimeout));
  EXPECT_TRUE(logs.sawTag("LOOP-EXCEPTION"));
}

TEST(Loop, OverloadIsMeasuredAndWarnedWithStableTag) {
  test::LogCapture logs;
  Loop loop(options(TimingMode::coarse, 5, 5));
  loop.addTickHandler(Tick::fast,
                      [] { std::this_thread::sleep_for(std::chrono::milliseconds(7)); });
  ASSERT_TRUE(loop.runUntil([&] { return loop.stats().one_sec_ticks >= 1; }, kLongTimeout));
  EXPECT_GE(loop.stats().work_ratio_mean, 1.0);
  EXPECT_GT(loop.stats().skipped_ticks, 0u);
  EXPECT_EQ(loop.stats().load_warnings, 1u);
  EXPECT_TRUE(logs.sawTag("LOOP-OVERLOAD"));
}

TEST(Loop, LightLoadGivesNoWarning) {
  test::LogCapture logs;
  Loop loop(options(TimingMode::coarse, 10, 100));
  ASSERT_TRUE(loop.runUntil([&] { return loop.stats().one_sec_ticks >= 1; }, kLongTimeout));
  EXPECT_LT(loop.stats().work_ratio_mean, 0.5);
  // A machine too busy to wake us in time makes the loop skip ticks, but those are late
  // wake-ups (counted), not the loop's work. Only a tick preempted in the middle of its work
  // (rare: it takes microseconds) counts as work; without that an idle loop stays quiet.
  if (loop.stats().skipped_ticks == loop.stats().late_skipped_ticks) {
    EXPECT_FALSE(logs.sawTag("LOOP-OVERLOAD"));
  }
}

// A wake-up made late by the thread being off the CPU (here blocked in posted work between
// ticks, as a busy machine's scheduler or a stopped process would hold it) skips ticks, but it
// is not the loop's work being too slow: counted, never warned.
TEST(Loop, LateWakeUpIsCountedNotWarned) {
  test::LogCapture logs;
  Loop loop(options(TimingMode::coarse, 5, 5));
  int ticks = 0;
  loop.addTickHandler(Tick::fast, [&] {
    if (++ticks % 20 == 3) {
      loop.post([] { std::this_thread::sleep_for(std::chrono::milliseconds(40)); });
    }
  });
  ASSERT_TRUE(loop.runUntil([&] { return loop.stats().one_sec_ticks >= 2; }, kLongTimeout));
  EXPECT_GE(loop.stats().late_wakeups, 2u);
  EXPECT_GE(loop.stats().late_skipped_ticks, 2 * loop.stats().late_wakeups);  // 40 ms of 5 ms
  EXPECT_EQ(loop.stats().load_warnings, 0u);
  EXPECT_FALSE(logs.sawTag("LOOP-OVERLOAD"));
}

// The same lateness with the thread on the CPU (posted work or I/O callbacks that ran past the
// deadline) is the loop's own work: it warns. The work is measured in CPU time, so a busy
// machine stretches it without making it look like a late wake-up.
TEST(Loop, WorkBetweenTicksPastTheDeadlineWarns) {
  test::LogCapture logs;
  Loop loop(options(TimingMode::coarse, 5, 5));
  int ticks = 0;
  loop.addTickHandler(Tick::fast, [&] {
    if (++ticks % 20 == 3) {
      loop.post([] {
        const Nanos until = threadCpuNs() + 40 * kNsPerMs;
        while (threadCpuNs() < until) {
        }
      });
    }
  });
  ASSERT_TRUE(loop.runUntil([&] { return loop.stats().one_sec_ticks >= 1; }, kLongTimeout));
  EXPECT_LT(loop.stats().work_ratio_mean, 0.8);  // not the ticks' work
  EXPECT_GT(loop.stats().skipped_ticks, loop.stats().late_skipped_ticks);
  EXPECT_EQ(loop.stats().load_warnings, 1u);
  EXPECT_TRUE(logs.sawTag("LOOP-OVERLOAD"));
}

TEST(LoopThread, RunsOnItsOwnThreadAndStopsCleanly) {
  LoopThread lt(options(TimingMode::coarse, 1, 10));
  lt.start();
  std::thread::id where;
  std::atomic<int> ticks{0};
  lt.loop().invoke([&] {
    where = std::this_thread::get_id();
    EXPECT_EQ(Loop::current(), &lt.loop());
    lt.loop().addTickHandler(Tick::fast, [&] { ++ticks; });
  });
  EXPECT_NE(where, std::this_thread::get_id());
  EXPECT_FALSE(lt.loop().isLoopThread());
  while (ticks < 3) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  lt.stop();
  lt.stop();  // idempotent
  EXPECT_TRUE(lt.loop().stopRequested());
}

TEST(LoopThread, InvokePropagatesExceptions) {
  LoopThread lt(LoopOptions{});
  lt.start();
  EXPECT_THROW(lt.loop().invoke([] { throw std::runtime_error("x"); }), std::runtime_error);
}

TEST(Loop, StopFromAnotherThreadEndsRun) {
  Loop loop;
  std::thread stopper([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    loop.stop();
  });
  loop.run();  // returns only because of stop()
  stopper.join();
  EXPECT_TRUE(loop.stopRequested());
}

}  // namespace
}  // namespace skr
