// SPDX-License-Identifier: Apache-2.0
// The loop's handles (skrobot/runtime/loop_handles.h): timers, the spinner, descriptor and POSIX
// signal watches, stopOnSignals.
#include "test_support.h"

#include <skrobot/runtime/loop_handles.h>

#include <gtest/gtest.h>

#include <fcntl.h>
#include <sys/socket.h>
#include <unistd.h>

#include <csignal>
#include <cstdio>
#include <memory>
#include <optional>
#include <stdexcept>
#include <thread>
#include <vector>

namespace skr {
namespace {

constexpr Nanos kLongTimeout = 20 * kNsPerSec;  // generous: tests must not fail on slow machines

// A connected pair of Unix stream sockets, closed at the end.
struct SocketPair {
  int fd[2] = {-1, -1};
  SocketPair() { EXPECT_EQ(::socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, fd), 0); }
  ~SocketPair() {
    for (int f : fd) {
      if (f >= 0) ::close(f);
    }
  }
  SocketPair(const SocketPair&) = delete;
  SocketPair& operator=(const SocketPair&) = delete;
};

// --- Timer ---------------------------------------------------------------------------------------

TEST(Timer, OnceFiresOnceNeverBeforeItsDeadline) {
  Loop loop;
  std::vector<Nanos> fired;
  Timer timer(loop, [&] { fired.push_back(monotonicNs()); });
  EXPECT_FALSE(timer.active());
  const Nanos deadline = monotonicNs() + 20 * kNsPerMs;
  timer.startAt(deadline);
  EXPECT_TRUE(timer.active());
  EXPECT_EQ(timer.deadline(), deadline);
  ASSERT_TRUE(loop.runUntil([&] { return !fired.empty(); }, kLongTimeout));
  EXPECT_GE(fired[0], deadline);
  EXPECT_FALSE(timer.active());
  loop.runFor(60 * kNsPerMs);
  EXPECT_EQ(fired.size(), 1u);
}

TEST(Timer, StartInAndStartingAgainReplacesThePendingFiring) {
  Loop loop;
  int fired = 0;
  Timer timer(loop, [&] { ++fired; });
  timer.startIn(10 * kNsPerSec);
  timer.startIn(5 * kNsPerMs);  // replaces the 10 s one
  ASSERT_TRUE(loop.runUntil([&] { return fired == 1; }, kLongTimeout));
  EXPECT_FALSE(timer.active());
}

// Periodic deadlines are absolute: every deadline is first + n * period, and a callback that
// holds the loop past several periods gets the next one in the future (the missed ones are
// skipped), not a burst of late firings.
TEST(Timer, RepeatsFromAbsoluteDeadlinesAndSkipsMissedPeriods) {
  Loop loop;
  constexpr Nanos kPeriod = 50 * kNsPerMs;
  const Nanos first = monotonicNs() + kPeriod;
  struct Firing {
    Nanos at, next;
  };
  std::vector<Firing> firings;
  Nanos held_until = 0;
  Timer timer;
  timer = Timer(loop, [&] {
    firings.push_back({monotonicNs(), timer.deadline()});
    if (firings.size() == 2) {
      std::this_thread::sleep_for(std::chrono::milliseconds(170));  // misses three periods
      held_until = monotonicNs();
    }
  });
  timer.startEvery(kPeriod, first);
  ASSERT_TRUE(loop.runUntil([&] { return firings.size() >= 5; }, kLongTimeout));
  EXPECT_TRUE(timer.active());
  for (size_t i = 0; i < firings.size(); ++i) {
    SCOPED_TRACE(i);
    EXPECT_EQ((firings[i].next - first) % kPeriod, 0);  // on the grid
    EXPECT_GT(firings[i].next, firings[i].at - kPeriod);
    if (i > 0) {
      EXPECT_GT(firings[i].next, firings[i - 1].next);
    }
  }
  // The firing after the held callback: its next deadline lies after the hold.
  EXPECT_GT(firings[2].next, held_until);
  EXPECT_GE(firings[2].next - firings[1].next, 3 * kPeriod);  // P without the skip
  timer.stop();
  EXPECT_FALSE(timer.active());
  const size_t n = firings.size();
  loop.runFor(3 * kPeriod);
  EXPECT_EQ(firings.size(), n);
}

TEST(Timer, ADestroyedOrStoppedTimerNeverFires) {
  Loop loop;
  int fired = 0;
  auto destroyed = std::make_unique<Timer>(loop, [&] { ++fired; });
  destroyed->startIn(0);
  destroyed.reset();
  Timer stopped(loop, [&] { ++fired; });
  stopped.startEvery(kNsPerMs);
  stopped.stop();
  Timer moved_over(loop, [&] { ++fired; });
  moved_over.startIn(0);
  moved_over = Timer(loop, [] {});
  loop.runFor(50 * kNsPerMs);
  EXPECT_EQ(fired, 0);
}

// Destroying a timer inside its own callback is allowed: the callback's captures stay alive until
// it returns, and it never runs again (AddressSanitizer checks the first half).
TEST(Timer, DestroyedInsideItsOwnCallback) {
  Loop loop;
  int fired = 0;
  std::optional<Timer> timer;
  auto payload = std::make_shared<int>(7);
  timer.emplace(loop, [&fired, &timer, payload] {
    ++fired;
    timer.reset();
    EXPECT_EQ(*payload, 7);  // the capture is still there
  });
  timer->startEvery(kNsPerMs);
  ASSERT_TRUE(loop.runUntil([&] { return fired == 1; }, kLongTimeout));
  loop.runFor(30 * kNsPerMs);
  EXPECT_EQ(fired, 1);
  EXPECT_EQ(payload.use_count(), 1);  // the callback went with the timer
}

TEST(Timer, MovedTimerKeepsRunning) {
  Loop loop;
  int fired = 0;
  Timer a(loop, [&] { ++fired; });
  a.startIn(5 * kNsPerMs);
  Timer b(std::move(a));
  EXPECT_FALSE(a);  // NOLINT(bugprone-use-after-move): moved-from is empty, on purpose
  EXPECT_FALSE(a.active());
  a.stop();  // does nothing on an empty handle
  EXPECT_TRUE(b.active());
  ASSERT_TRUE(loop.runUntil([&] { return fired == 1; }, kLongTimeout));
}

TEST(Timer, ThrowingCallbackIsLoggedAndTheLoopGoesOn) {
  test::LogCapture logs;
  Loop loop;
  int fired = 0;
  Timer timer(loop, [&] {
    ++fired;
    throw std::runtime_error("boom");
  });
  timer.startEvery(kNsPerMs);
  ASSERT_TRUE(loop.runUntil([&] { return fired >= 3; }, kLongTimeout));
  EXPECT_TRUE(logs.sawTag("LOOP-EXCEPTION"));
}

TEST(LoopHandlesDeathTest, TimerMadeOffTheLoopThreadAborts) {
  ::testing::GTEST_FLAG(death_test_style) = "threadsafe";
  EXPECT_DEATH(
      {
        LoopThread t(LoopOptions{.name = "bound"});
        t.start();
        Timer timer(t.loop(), [] {});
      },
      "Timer::Timer called off loop 'bound''s thread");
}

// --- Spinner -------------------------------------------------------------------------------------

TEST(Spinner, RunsOnEveryTurnWhileStartedAndTheLoopDoesNotSleep) {
  // A 10 s fast interval: a loop that sleeps turns a handful of times in 200 ms.
  Loop loop(LoopOptions{.fast_interval_ns = 10 * kNsPerSec, .slow_interval_ns = 10 * kNsPerSec});
  int turns = 0;
  Spinner spinner(loop, [&] { ++turns; });
  loop.runFor(100 * kNsPerMs);
  EXPECT_EQ(turns, 0);  // not started
  spinner.start();
  spinner.start();  // idempotent
  EXPECT_TRUE(spinner.active());
  loop.runFor(200 * kNsPerMs);
  EXPECT_GT(turns, 100);
  spinner.stop();
  EXPECT_FALSE(spinner.active());
  const int before = turns;
  loop.runFor(100 * kNsPerMs);
  EXPECT_EQ(turns, before);
}

// --- FdWatch -------------------------------------------------------------------------------------

TEST(FdWatch, ReportsWritableThenReadableThenHangupOnASocketPair) {
  Loop loop;
  SocketPair sp;
  std::vector<unsigned> seen;
  auto watch = FdWatch::open(loop, sp.fd[0], [&](unsigned events) { seen.push_back(events); });
  ASSERT_TRUE(watch) << watch.error().message;
  EXPECT_EQ(watch->fd(), sp.fd[0]);
  EXPECT_NE(::fcntl(sp.fd[0], F_GETFL) & O_NONBLOCK, 0);  // made non-blocking
  loop.runFor(20 * kNsPerMs);
  EXPECT_TRUE(seen.empty());  // nothing waited for yet

  // An empty socket has room to write.
  watch->watch(FdWatch::writable);
  EXPECT_EQ(watch->watching(), unsigned(FdWatch::writable));
  ASSERT_TRUE(loop.runUntil([&] { return !seen.empty(); }, kLongTimeout));
  EXPECT_EQ(seen.back(), unsigned(FdWatch::writable));

  // Readable once the peer wrote (and not before).
  watch->watch(FdWatch::readable | FdWatch::hangup);
  seen.clear();
  loop.runFor(20 * kNsPerMs);
  EXPECT_TRUE(seen.empty());
  ASSERT_EQ(::write(sp.fd[1], "x", 1), 1);
  ASSERT_TRUE(loop.runUntil([&] { return !seen.empty(); }, kLongTimeout));
  EXPECT_EQ(seen.back(), unsigned(FdWatch::readable));
  char c = 0;
  ASSERT_EQ(::read(sp.fd[0], &c, 1), 1);

  // The peer closes: readable (the end of the stream) with hangup.
  seen.clear();
  ::close(sp.fd[1]);
  sp.fd[1] = -1;
  ASSERT_TRUE(loop.runUntil([&] { return !seen.empty(); }, kLongTimeout));
  EXPECT_NE(seen.back() & FdWatch::hangup, 0u);
  EXPECT_NE(seen.back() & FdWatch::readable, 0u);
}

TEST(FdWatch, StopsOnDestructionAndOnStop) {
  Loop loop;
  SocketPair sp;
  int calls = 0;
  auto watch = FdWatch::open(loop, sp.fd[0], [&](unsigned) { ++calls; });
  ASSERT_TRUE(watch);
  watch->watch(FdWatch::readable);
  ASSERT_EQ(::write(sp.fd[1], "x", 1), 1);  // stays unread: level-triggered, it would go on
  ASSERT_TRUE(loop.runUntil([&] { return calls > 0; }, kLongTimeout));
  watch->stop();
  EXPECT_EQ(watch->watching(), 0u);
  calls = 0;
  loop.runFor(20 * kNsPerMs);
  EXPECT_EQ(calls, 0);
  watch->watch(FdWatch::readable);  // again after a stop
  ASSERT_TRUE(loop.runUntil([&] { return calls > 0; }, kLongTimeout));
  { FdWatch gone = std::move(*watch); }
  calls = 0;
  loop.runFor(20 * kNsPerMs);
  EXPECT_EQ(calls, 0);
  // Its descriptor can be watched again once the watch is gone.
  auto again = FdWatch::open(loop, sp.fd[0], [&](unsigned) { ++calls; });
  ASSERT_TRUE(again) << again.error().message;
  again->watch(FdWatch::readable);
  ASSERT_TRUE(loop.runUntil([&] { return calls > 0; }, kLongTimeout));
}

// A watch that destroys itself in its callback (a peer closed on hang-up) is never called again,
// and the callback's captures outlive the call (AddressSanitizer).
TEST(FdWatch, DestroyedInsideItsOwnCallback) {
  Loop loop;
  SocketPair sp;
  int calls = 0;
  std::optional<FdWatch> watch;
  auto payload = std::make_shared<int>(7);
  auto opened = FdWatch::open(loop, sp.fd[0], [&calls, &watch, payload](unsigned) {
    ++calls;
    watch.reset();
    EXPECT_EQ(*payload, 7);
  });
  ASSERT_TRUE(opened);
  watch.emplace(std::move(*opened));
  watch->watch(FdWatch::readable);
  ASSERT_EQ(::write(sp.fd[1], "x", 1), 1);
  ASSERT_TRUE(loop.runUntil([&] { return calls > 0; }, kLongTimeout));
  loop.runFor(20 * kNsPerMs);
  EXPECT_EQ(calls, 1);
}

TEST(FdWatch, ADescriptorThatCannotBePolledIsAnError) {
  Loop loop;
  std::FILE* file = std::tmpfile();
  ASSERT_NE(file, nullptr);
  auto watch = FdWatch::open(loop, ::fileno(file), [](unsigned) {});
  std::fclose(file);
  ASSERT_FALSE(watch);
  EXPECT_EQ(watch.error().code, Errc::io_error);
  EXPECT_NE(watch.error().message.find("cannot poll descriptor"), std::string::npos)
      << watch.error().message;
}

// --- SignalWatch, stopOnSignals ------------------------------------------------------------------

TEST(SignalWatch, SeesARaisedSignalOnTheLoopThread) {
  Loop loop;
  int got = 0;
  std::thread::id where;
  auto watch = SignalWatch::open(loop, SIGUSR1, [&](int signum) {
    got = signum;
    where = std::this_thread::get_id();
  });
  ASSERT_TRUE(watch) << watch.error().message;
  EXPECT_EQ(watch->signum(), SIGUSR1);
  ASSERT_EQ(std::raise(SIGUSR1), 0);
  EXPECT_EQ(got, 0);  // not in signal context: from the loop
  ASSERT_TRUE(loop.runUntil([&] { return got != 0; }, kLongTimeout));
  EXPECT_EQ(got, SIGUSR1);
  EXPECT_EQ(where, std::this_thread::get_id());
  watch->stop();
  EXPECT_FALSE(*watch);
  EXPECT_EQ(watch->signum(), 0);
}

TEST(SignalWatch, ASignalThatCannotBeCaughtIsAnError) {
  Loop loop;
  auto watch = SignalWatch::open(loop, SIGKILL, [](int) {});
  ASSERT_FALSE(watch);
  EXPECT_EQ(watch.error().code, Errc::invalid_argument);
}

class StopOnSignalsTest : public ::testing::TestWithParam<int> {};

TEST_P(StopOnSignalsTest, StopsTheLoopAndSaysWhich) {
  Loop loop;
  int got = 0;
  const auto signals = stopOnSignals(loop, [&](int signum) { got = signum; });
  ASSERT_TRUE(signals.watching());
  loop.post([signum = GetParam()] { std::raise(signum); });
  // runUntil returns early when the loop is stopped; it would otherwise wait the whole timeout.
  EXPECT_FALSE(loop.runUntil([] { return false; }, kLongTimeout));
  EXPECT_TRUE(loop.stopRequested());
  EXPECT_EQ(got, GetParam());
}

INSTANTIATE_TEST_SUITE_P(IntAndTerm, StopOnSignalsTest, ::testing::Values(SIGINT, SIGTERM));

}  // namespace
}  // namespace skr
