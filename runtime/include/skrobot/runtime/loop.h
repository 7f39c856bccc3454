// SPDX-License-Identifier: Apache-2.0
// The event loop: one per thread, on libuv. It emits FastTick, SlowTick and OneSecTick from
// absolute deadlines, runs work posted from other threads, and measures itself.
//
// Vocabulary:
// - pulse: the moment the loop runs the work queued with post(). It happens on the loop thread,
//   after the current callback returns to the loop, never inside a caller's stack. Signal attach
//   and detach, queued slot calls and deferred deletions all take effect at the next pulse.
// - ticks: FastTick every fast interval (the loop's resolution), SlowTick every slow interval
//   (>= fast), OneSecTick every second. Slow and one-second ticks are checked at each fast tick;
//   when several fall due at once they run in the order fast, slow, one-second. A tick whose
//   deadline passed by more than a whole interval is skipped and counted, never run in a burst.
// - late wake-up: the loop woke a whole fast interval or more after its deadline while its thread
//   was off the CPU (not scheduled on a busy machine, stopped, or blocked in a call): counted,
//   and its skipped ticks are not the loop's work being too slow (no LOOP-OVERLOAD for them).
//
// Timers, a function run on every turn, descriptor and POSIX signal watches on a loop:
// skrobot/runtime/loop_handles.h.
#pragma once

#include <skrobot/runtime/clock.h>

#include <atomic>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

struct uv_loop_s;
struct uv_async_s;
struct uv_timer_s;
struct uv_idle_s;
struct uv_check_s;

namespace skr {

enum class TimingMode {
  coarse,           // sleep until the next deadline (millisecond timers); cheapest
  pseudo_realtime,  // sleep until shortly before the deadline, then spin; precise, costs CPU
  socket_driven,    // the fast interval is the longest wait for I/O; ticks come early on I/O
  none,             // no waiting: ticks run back to back, the tick's own work blocks
};

[[nodiscard]] std::string_view timingModeName(TimingMode mode) noexcept;
// Accepts "coarse", "pseudo-realtime", "socket-driven", "none".
bool parseTimingMode(std::string_view text, TimingMode& out) noexcept;

struct LoopOptions {
  std::string name = "main";
  TimingMode mode = TimingMode::coarse;
  Nanos fast_interval_ns = 10 * kNsPerMs;
  Nanos slow_interval_ns = 100 * kNsPerMs;  // raised to fast_interval_ns if smaller
  // Log LOOP-OVERLOAD when tick work over a second averages more than this fraction of the
  // fast interval, or when the loop's own work (its ticks, or callbacks that kept it on the CPU
  // past a deadline) made it skip ticks. Late wake-ups are counted instead (LoopStats).
  double load_warning_ratio = 0.8;
  // pseudo_realtime only: how long before each deadline the loop stops sleeping and spins.
  Nanos spin_margin_ns = 1500 * 1000;
  // After I/O (noteActivity), keep polling without sleeping this long: the next message is
  // served without a thread wake-up (lower latency), at the cost of CPU. 0: off.
  Nanos busy_poll_ns = 0;
};

enum class Tick { fast = 0, slow = 1, one_sec = 2 };

// Figures a loop keeps about itself. Updated on the loop thread; read them there, or after run()
// returned.
struct LoopStats {
  std::uint64_t fast_ticks = 0;
  std::uint64_t slow_ticks = 0;
  std::uint64_t one_sec_ticks = 0;
  std::uint64_t skipped_ticks = 0;  // fast deadlines skipped, for whatever reason
  // Wake-ups a whole fast interval or more after their deadline while the thread was off the
  // CPU (coarse and pseudo-realtime modes), and the fast deadlines they skipped (of
  // skipped_ticks): the machine's doing, not the loop's work.
  std::uint64_t late_wakeups = 0;
  std::uint64_t late_skipped_ticks = 0;
  std::uint64_t pulses = 0;         // pulses that ran posted work
  std::uint64_t posted = 0;         // functions run from post()
  std::uint64_t load_warnings = 0;  // LOOP-OVERLOAD lines logged
  double fast_rate_hz = 0;          // fast ticks per second, over the last full second
  double work_ratio_mean = 0;       // tick work / fast interval, mean over the last second
  double work_ratio_max = 0;        // and its maximum over the last second
};

using TickId = std::uint64_t;

class Loop {
 public:
  explicit Loop(LoopOptions options = {});
  ~Loop();
  Loop(const Loop&) = delete;
  Loop& operator=(const Loop&) = delete;
  Loop(Loop&&) = delete;
  Loop& operator=(Loop&&) = delete;

  // Runs until stop(). Binds the loop to the calling thread for its whole life; all run* calls
  // must come from that thread. Ticks start with the first run* call.
  void run();
  // Runs for at most `duration_ns`, or until stop(). Returns early if stopped.
  void runFor(Nanos duration_ns);
  // Runs until `done()` is true (checked after every loop iteration) or `timeout_ns` passed.
  // Returns done()'s last value. For tests and start-up sequences.
  bool runUntil(const std::function<bool()>& done, Nanos timeout_ns);

  // Thread-safe, idempotent. The running run* call returns after the current callback.
  void stop() noexcept;
  [[nodiscard]] bool stopRequested() const noexcept { return stop_requested_.load(); }

  // Thread-safe. Queues `fn` to run on the loop thread at the next pulse and wakes the loop.
  // Functions run in the order they were posted. Work posted after the loop was destroyed is
  // not possible: the owner must outlive its posters (LoopThread joins before destruction).
  void post(std::function<void()> fn);

  // Runs `fn` on the loop thread and waits until it returned. Runs it directly when called on
  // the loop thread. The loop must be running (or about to run) on another thread otherwise.
  void invoke(const std::function<void()>& fn);

  // Loop thread only (or before the loop runs): a call from another thread once the loop is bound
  // aborts (requireLoopThread). Handlers run in the order they were added. A handler added
  // during a tick runs from the next one; a removed one never runs again.
  TickId addTickHandler(Tick which, std::function<void()> handler);
  void removeTickHandler(TickId id) noexcept;

  // Loop thread only. Says that I/O just happened: with busy_poll_ns > 0 the loop polls without
  // sleeping until busy_poll_ns passed without further activity.
  void noteActivity() noexcept;

  // The loop bound to the calling thread (set by run*), or nullptr.
  [[nodiscard]] static Loop* current() noexcept;
  [[nodiscard]] bool isLoopThread() const noexcept;
  // Enforces a "loop thread only" contract in every build: once the loop is bound to a thread,
  // a call from any other thread writes "skrobot: <what> called off loop '<name>''s thread" to
  // stderr and aborts, as a second run* thread does. Before the loop is bound, any thread passes.
  void requireLoopThread(const char* what) const noexcept;
  // requireLoopThread in builds without NDEBUG (debug, AddressSanitizer), nothing in release:
  // for checks on hot paths of state owned by the loop's thread (docs/internals.md, "Threads and
  // what each owns").
  void debugRequireLoopThread([[maybe_unused]] const char* what) const noexcept {
#ifndef NDEBUG
    requireLoopThread(what);
#endif
  }
  [[nodiscard]] const LoopOptions& options() const noexcept {
    return options_;
  }
  [[nodiscard]] const std::string& name() const noexcept {
    return options_.name;
  }
  [[nodiscard]] const LoopStats& stats() const noexcept {
    return stats_;
  }

  // The libuv loop, for the runtime's own transports (the hub's server and connections, the
  // satellite library's link to its hub, loop_handles.h). Do not use it in new code: timers,
  // descriptor and signal watches are in skrobot/runtime/loop_handles.h. Loop thread only.
  [[nodiscard]] uv_loop_s* uv() noexcept {
    return uv_;
  }

 private:
  struct Handler {
    TickId id;
    std::function<void()> fn;
    bool removed = false;
  };

  void bindThread();
  void startTicks();
  void armFastTimer(Nanos now);
  void fireTicks(Nanos now);
  void dispatch(Tick which);
  void armTimerAt(Nanos target_ns);
  void measureSecond(Nanos now);
  void pulse();

  static void onAsync(uv_async_s* handle);
  static void onTimer(uv_timer_s* handle);
  static void onIdle(uv_idle_s* handle);
  static void onCheck(uv_check_s* handle);
  static void onStopTimer(uv_timer_s* handle);
  static void onBusyIdle(uv_idle_s* handle);

  LoopOptions options_;
  uv_loop_s* uv_ = nullptr;
  uv_async_s* async_ = nullptr;
  uv_timer_s* timer_ = nullptr;       // wakes the loop for the next fast deadline
  uv_timer_s* stop_timer_ = nullptr;  // runFor/runUntil time limits
  uv_idle_s* idle_ = nullptr;         // keeps the loop polling without sleep (spin, none mode)
  uv_check_s* check_ = nullptr;       // socket-driven: a tick after each I/O wake-up
  uv_idle_s* busy_idle_ = nullptr;    // busy polling after I/O (busy_poll_ns)
  bool busy_ = false;
  Nanos last_activity_ns_ = 0;

  std::atomic<std::thread::id> thread_{};
  std::atomic<bool> stop_requested_{false};
  bool ticks_started_ = false;

  std::mutex post_mutex_;
  std::vector<std::function<void()>> posted_;
  // Posted work taken from posted_ and not run yet (loop thread only): a pulse runs work until
  // kPulseBudgetNs have passed and leaves the rest for the next iteration, after the I/O that
  // became ready meanwhile (a long batch of posted work does not hold up a ping).
  std::deque<std::function<void()>> runnable_;

  std::vector<Handler> handlers_[3];
  std::vector<Handler> added_during_dispatch_[3];
  bool dispatching_ = false;
  bool handlers_dirty_ = false;
  TickId next_tick_id_ = 1;

  Nanos fast_deadline_ = 0;
  Nanos slow_deadline_ = 0;
  Nanos sec_deadline_ = 0;

  // Self-measurement over the current second.
  LoopStats stats_;
  Nanos window_start_ = 0;
  std::uint64_t window_ticks_ = 0;
  std::uint64_t window_skipped_ = 0;       // by the loop's work
  std::uint64_t window_late_skipped_ = 0;  // after late wake-ups
  double window_work_sum_ = 0;
  double window_work_max_ = 0;
  Nanos last_warning_ns_ = 0;
  std::uint64_t suppressed_warnings_ = 0;
  // The thread's CPU time when the last tick's work ended (coarse and pseudo-realtime): what it
  // did between then and a late wake-up tells work from not being scheduled.
  Nanos cpu_at_tick_end_ = 0;
};

// A Loop that runs on a thread of its own (a module that asks for its own thread).
class LoopThread {
 public:
  explicit LoopThread(LoopOptions options);
  ~LoopThread();  // stops the loop and joins
  LoopThread(const LoopThread&) = delete;
  LoopThread& operator=(const LoopThread&) = delete;
  LoopThread(LoopThread&&) = delete;
  LoopThread& operator=(LoopThread&&) = delete;

  // Starts the thread; returns once the loop is running.
  void start();
  // Stops the loop and joins the thread. Idempotent.
  void stop() noexcept;
  [[nodiscard]] Loop& loop() noexcept { return *loop_; }

 private:
  std::unique_ptr<Loop> loop_;
  std::thread thread_;
};

}  // namespace skr
