// SPDX-License-Identifier: Apache-2.0
#include <skrobot/runtime/log.h>
#include <skrobot/runtime/loop.h>
#include "loop_internal.h"
#include "uv_handle.h"

#include <pthread.h>
#include <uv.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <future>
#include <string>

namespace skr {
namespace {

thread_local Loop* t_current = nullptr;

constexpr Nanos kOneSecond = kNsPerSec;
constexpr Nanos kWarningInterval = 10 * kNsPerSec;       // at most one LOOP-OVERLOAD line per 10 s
constexpr Nanos kPulseBudgetNs = 100 * kNsPerMs / 1000;  // posted work run before I/O gets a turn

}  // namespace

std::string_view timingModeName(TimingMode mode) noexcept {
  switch (mode) {
    case TimingMode::coarse:
      return "coarse";
    case TimingMode::pseudo_realtime:
      return "pseudo-realtime";
    case TimingMode::socket_driven:
      return "socket-driven";
    case TimingMode::none:
      return "none";
  }
  return "?";
}

bool parseTimingMode(std::string_view text, TimingMode& out) noexcept {
  for (TimingMode m : {TimingMode::coarse, TimingMode::pseudo_realtime, TimingMode::socket_driven,
                       TimingMode::none}) {
    if (text == timingModeName(m)) {
      out = m;
      return true;
    }
  }
  return false;
}

Loop::Loop(LoopOptions options) : options_(std::move(options)) {
  if (options_.fast_interval_ns < 1000) options_.fast_interval_ns = 1000;
  options_.slow_interval_ns = std::max(options_.slow_interval_ns, options_.fast_interval_ns);
  uv_ = new uv_loop_t{};
  if (int rc = uv_loop_init(uv_); rc != 0) {
    std::fprintf(stderr, "uv_loop_init failed: %s\n", uv_strerror(rc));
    std::abort();  // nothing can run without a loop
  }
  async_ = newUvHandle<uv_async_t>(this);
  uv_async_init(uv_, async_, &Loop::onAsync);
  timer_ = newUvHandle<uv_timer_t>(this);
  uv_timer_init(uv_, timer_);
  stop_timer_ = newUvHandle<uv_timer_t>(this);
  uv_timer_init(uv_, stop_timer_);
  idle_ = newUvHandle<uv_idle_t>(this);
  uv_idle_init(uv_, idle_);
  check_ = newUvHandle<uv_check_t>(this);
  uv_check_init(uv_, check_);
  busy_idle_ = newUvHandle<uv_idle_t>(this);
  uv_idle_init(uv_, busy_idle_);
}

Loop::~Loop() {
  closeUvHandle(async_);
  closeUvHandle(timer_);
  closeUvHandle(stop_timer_);
  closeUvHandle(idle_);
  closeUvHandle(check_);
  closeUvHandle(busy_idle_);
  // Let close callbacks run; handles opened by others on this loop must be closed by now.
  uv_run(uv_, UV_RUN_NOWAIT);
  if (uv_loop_close(uv_) != 0) {
    // Somebody left a handle open: walk and close them so that nothing leaks.
    uv_walk(
        uv_,
        [](uv_handle_t* h, void*) {
          if (!uv_is_closing(h)) uv_close(h, nullptr);
        },
        nullptr);
    uv_run(uv_, UV_RUN_DEFAULT);
    uv_loop_close(uv_);
  }
  delete uv_;
  if (t_current == this) t_current = nullptr;
}

Loop* Loop::current() noexcept {
  return t_current;
}

bool Loop::isLoopThread() const noexcept {
  return thread_.load() == std::this_thread::get_id();
}

void Loop::requireLoopThread(const char* what) const noexcept {
  const std::thread::id bound = thread_.load();
  if (bound == std::thread::id{} || bound == std::this_thread::get_id()) return;
  std::fprintf(stderr, "skrobot: %s called off loop '%s''s thread\n", what, options_.name.c_str());
  std::abort();  // a contract violation: the handler lists are not thread-safe
}

void Loop::bindThread() {
  const auto self = std::this_thread::get_id();
  std::thread::id expected{};
  if (!thread_.compare_exchange_strong(expected, self) && expected != self) {
    std::fprintf(stderr, "skrobot: loop '%s' run from a second thread\n", options_.name.c_str());
    std::abort();  // a contract violation that would corrupt libuv state
  }
  t_current = this;
}

void Loop::run() {
  bindThread();
  startTicks();
  while (!stop_requested_.load()) uv_run(uv_, UV_RUN_DEFAULT);
}

void Loop::runFor(Nanos duration_ns) {
  runUntil([] { return false; }, duration_ns);
}

bool Loop::runUntil(const std::function<bool()>& done, Nanos timeout_ns) {
  bindThread();
  startTicks();
  const Nanos deadline = monotonicNs() + timeout_ns;
  const auto timeout_ms = static_cast<uint64_t>((timeout_ns + kNsPerMs - 1) / kNsPerMs);
  uv_update_time(uv_);
  uv_timer_start(stop_timer_, &Loop::onStopTimer, timeout_ms, 0);
  bool result = done();
  while (!result && !stop_requested_.load() && monotonicNs() < deadline) {
    uv_run(uv_, UV_RUN_ONCE);
    result = done();
  }
  uv_timer_stop(stop_timer_);
  return result;
}

void Loop::stop() noexcept {
  stop_requested_.store(true);
  uv_async_send(async_);
}

void Loop::post(std::function<void()> fn) {
  {
    std::lock_guard lock(post_mutex_);
    posted_.push_back(std::move(fn));
  }
  uv_async_send(async_);
}

void Loop::invoke(const std::function<void()>& fn) {
  if (isLoopThread()) {
    fn();
    return;
  }
  std::promise<void> done;
  auto finished = done.get_future();
  post([&fn, &done] {
    try {
      fn();
      done.set_value();
    } catch (...) {
      done.set_exception(std::current_exception());
    }
  });
  finished.get();
}

TickId Loop::addTickHandler(Tick which, std::function<void()> handler) {
  requireLoopThread("Loop::addTickHandler");
  const TickId id = next_tick_id_++;
  auto& list = dispatching_ ? added_during_dispatch_[static_cast<int>(which)]
                            : handlers_[static_cast<int>(which)];
  list.push_back(Handler{id, std::move(handler)});
  return id;
}

void Loop::removeTickHandler(TickId id) noexcept {
  for (int i = 0; i < 3; ++i) {
    for (auto* list : {&handlers_[i], &added_during_dispatch_[i]}) {
      for (auto& h : *list) {
        if (h.id == id) {
          h.removed = true;
          handlers_dirty_ = true;
        }
      }
    }
  }
}

void Loop::dispatch(Tick which) {
  auto& list = handlers_[static_cast<int>(which)];
  dispatching_ = true;
  // Index loop: handlers added meanwhile wait in added_during_dispatch_, so `list` never grows.
  for (size_t i = 0; i < list.size(); ++i) {
    if (!list[i].removed) detail::runGuarded(options_.name, "tick handler", list[i].fn);
  }
  dispatching_ = false;
  for (int i = 0; i < 3; ++i) {
    auto& added = added_during_dispatch_[i];
    if (added.empty()) continue;
    std::move(added.begin(), added.end(), std::back_inserter(handlers_[i]));
    added.clear();
  }
  if (handlers_dirty_) {
    for (auto& l : handlers_) std::erase_if(l, [](const Handler& h) { return h.removed; });
    handlers_dirty_ = false;
  }
}

void Loop::startTicks() {
  if (ticks_started_) return;
  ticks_started_ = true;
  const Nanos now = monotonicNs();
  fast_deadline_ = now + options_.fast_interval_ns;
  slow_deadline_ = now + options_.slow_interval_ns;
  sec_deadline_ = now + kOneSecond;
  window_start_ = now;
  cpu_at_tick_end_ = threadCpuNs();
  switch (options_.mode) {
    case TimingMode::coarse:
    case TimingMode::pseudo_realtime:
      armFastTimer(now);
      break;
    case TimingMode::socket_driven:
      uv_check_start(check_, &Loop::onCheck);
      armTimerAt(fast_deadline_);
      break;
    case TimingMode::none:
      uv_idle_start(idle_, &Loop::onIdle);
      break;
  }
}

void Loop::armTimerAt(Nanos target_ns) {
  // Never before target_ns on a precise clock; onTimer re-checks for coarse clocks.
  uv_timer_start(timer_, &Loop::onTimer, detail::uvTimeoutMs(uv_, target_ns), 0);
}

void Loop::armFastTimer(Nanos now) {
  if (options_.mode == TimingMode::pseudo_realtime) {
    const Nanos wake = fast_deadline_ - options_.spin_margin_ns;
    if (wake <= now) {
      uv_idle_start(idle_, &Loop::onIdle);
      return;
    }
    armTimerAt(wake);
    return;
  }
  armTimerAt(fast_deadline_);
}

void Loop::onTimer(uv_timer_t* handle) {
  auto* self = static_cast<Loop*>(handle->data);
  const Nanos now = monotonicNs();
  switch (self->options_.mode) {
    case TimingMode::coarse:
      if (now < self->fast_deadline_ - 100'000) {
        // libuv's clock was coarser than ours: wait the rest (at least 1 ms, never spin).
        uv_timer_start(self->timer_, &Loop::onTimer, 1, 0);
        return;
      }
      self->fireTicks(now);
      break;
    case TimingMode::pseudo_realtime:
      uv_idle_start(self->idle_, &Loop::onIdle);
      break;
    case TimingMode::socket_driven:
      // The longest wait is over. libuv may run this in its timer phase, before the poll, so
      // tick (and re-arm) here: leaving it to onCheck would let the poll sleep with no timer.
      self->fireTicks(now);
      break;
    case TimingMode::none:
      break;  // onIdle ticks
  }
}

void Loop::onIdle(uv_idle_t* handle) {
  auto* self = static_cast<Loop*>(handle->data);
  const Nanos now = monotonicNs();
  if (self->options_.mode == TimingMode::none) {
    self->fireTicks(now);
    return;
  }
  // pseudo-realtime: poll without sleeping (I/O still runs) until the deadline.
  if (now < self->fast_deadline_) return;
  uv_idle_stop(self->idle_);
  self->fireTicks(now);
}

void Loop::onCheck(uv_check_t* handle) {
  // socket-driven: every wake-up (I/O, posted work or the timer) is a tick.
  auto* self = static_cast<Loop*>(handle->data);
  self->fireTicks(monotonicNs());
}

void Loop::onStopTimer(uv_timer_t*) {}

void Loop::noteActivity() noexcept {
  if (options_.busy_poll_ns <= 0) return;
  last_activity_ns_ = monotonicNs();
  if (!busy_) {
    busy_ = true;
    uv_idle_start(busy_idle_, &Loop::onBusyIdle);  // an active idle handle makes the poll not wait
  }
}

void Loop::onBusyIdle(uv_idle_t* handle) {
  auto* self = static_cast<Loop*>(handle->data);
  if (monotonicNs() - self->last_activity_ns_ > self->options_.busy_poll_ns) {
    self->busy_ = false;
    uv_idle_stop(self->busy_idle_);
  }
}  // only wakes runUntil's uv_run(UV_RUN_ONCE)

void Loop::onAsync(uv_async_t* handle) {
  auto* self = static_cast<Loop*>(handle->data);
  if (self->stop_requested_.load()) uv_stop(self->uv_);
  self->pulse();
}

void Loop::pulse() {
  {
    std::lock_guard lock(post_mutex_);
    for (auto& fn : posted_) runnable_.push_back(std::move(fn));
    posted_.clear();
  }
  if (runnable_.empty()) return;
  ++stats_.pulses;
  const Nanos until = monotonicNs() + kPulseBudgetNs;
  while (!runnable_.empty()) {
    auto fn = std::move(runnable_.front());
    runnable_.pop_front();
    ++stats_.posted;
    detail::runGuarded(options_.name, "posted work", fn);
    if (!runnable_.empty() && monotonicNs() >= until) {
      uv_async_send(async_);  // the rest after this iteration's I/O
      break;
    }
  }
}

void Loop::fireTicks(Nanos now) {
  const Nanos interval = options_.fast_interval_ns;
  const bool deadlines =
      options_.mode == TimingMode::coarse || options_.mode == TimingMode::pseudo_realtime;
  // A wake-up a whole interval late skips ticks. When the thread spent most of that time off
  // the CPU (not scheduled, stopped, blocked: it ran for less than a quarter of it since the
  // last tick), the lateness is the machine's, not the loop's work: callbacks that ran past the
  // deadline would have used the CPU for it (a quarter leaves room for a busy machine that
  // shares the CPU with them).
  bool late_wakeup = false;
  if (deadlines && now - fast_deadline_ >= interval) {
    late_wakeup = (threadCpuNs() - cpu_at_tick_end_) * 4 < now - fast_deadline_;
  }
  ++stats_.fast_ticks;
  ++window_ticks_;
  dispatch(Tick::fast);
  if (now >= slow_deadline_) {
    ++stats_.slow_ticks;
    dispatch(Tick::slow);
    slow_deadline_ += options_.slow_interval_ns;
    if (slow_deadline_ <= now) {
      slow_deadline_ +=
          ((now - slow_deadline_) / options_.slow_interval_ns + 1) * options_.slow_interval_ns;
    }
  }
  if (now >= sec_deadline_) {
    measureSecond(now);
    ++stats_.one_sec_ticks;
    dispatch(Tick::one_sec);
    sec_deadline_ += kOneSecond;
    if (sec_deadline_ <= now)
      sec_deadline_ += ((now - sec_deadline_) / kOneSecond + 1) * kOneSecond;
  }
  const Nanos end = monotonicNs();
  if (deadlines) cpu_at_tick_end_ = threadCpuNs();
  const double ratio = static_cast<double>(end - now) / static_cast<double>(interval);
  window_work_sum_ += ratio;
  window_work_max_ = std::max(window_work_max_, ratio);

  switch (options_.mode) {
    case TimingMode::coarse:
    case TimingMode::pseudo_realtime:
      fast_deadline_ += interval;
      if (fast_deadline_ <= end) {
        // Work overran whole periods: skip them rather than tick in a burst; keep the phase.
        const Nanos missed = (end - fast_deadline_) / interval + 1;
        stats_.skipped_ticks += static_cast<uint64_t>(missed);
        if (late_wakeup) {
          // Those the tick's work would have skipped after an on-time wake-up stay the work's.
          const Nanos by_work = std::min(missed, (end - now) / interval);
          window_skipped_ += static_cast<uint64_t>(by_work);
          window_late_skipped_ += static_cast<uint64_t>(missed - by_work);
          stats_.late_skipped_ticks += static_cast<uint64_t>(missed - by_work);
          ++stats_.late_wakeups;
        } else {
          window_skipped_ += static_cast<uint64_t>(missed);
        }
        fast_deadline_ += missed * interval;
      }
      armFastTimer(end);
      break;
    case TimingMode::socket_driven:
      fast_deadline_ = end + interval;  // the longest wait for I/O
      armTimerAt(fast_deadline_);
      break;
    case TimingMode::none:
      break;
  }
}

void Loop::measureSecond(Nanos now) {
  const double elapsed_s = static_cast<double>(now - window_start_) / kNsPerSec;
  stats_.fast_rate_hz = elapsed_s > 0 ? static_cast<double>(window_ticks_) / elapsed_s : 0;
  stats_.work_ratio_mean = window_ticks_ > 0 ? window_work_sum_ / window_ticks_ : 0;
  stats_.work_ratio_max = window_work_max_;
  const bool overloaded =
      options_.mode != TimingMode::none &&
      (stats_.work_ratio_mean >= options_.load_warning_ratio || window_skipped_ > 0);
  if (overloaded) {
    if (last_warning_ns_ == 0 || now - last_warning_ns_ >= kWarningInterval) {
      char buf[256];
      std::snprintf(buf, sizeof buf,
                    "loop %s: tick work %.0f%% of the %.3f ms interval on average (max %.0f%%), "
                    "%llu ticks skipped by its work in the last second (%llu more after late "
                    "wake-ups), %llu warnings suppressed",
                    options_.name.c_str(), stats_.work_ratio_mean * 100,
                    static_cast<double>(options_.fast_interval_ns) / kNsPerMs,
                    stats_.work_ratio_max * 100, static_cast<unsigned long long>(window_skipped_),
                    static_cast<unsigned long long>(window_late_skipped_),
                    static_cast<unsigned long long>(suppressed_warnings_));
      log::warn("core.loop", "LOOP-OVERLOAD", buf);
      ++stats_.load_warnings;
      last_warning_ns_ = now;
      suppressed_warnings_ = 0;
    } else {
      ++suppressed_warnings_;
    }
  }
  window_start_ = now;
  window_ticks_ = 0;
  window_skipped_ = 0;
  window_late_skipped_ = 0;
  window_work_sum_ = 0;
  window_work_max_ = 0;
}

LoopThread::LoopThread(LoopOptions options) : loop_(std::make_unique<Loop>(std::move(options))) {}

LoopThread::~LoopThread() {
  stop();
}

void LoopThread::start() {
  if (thread_.joinable()) return;
  std::promise<void> running;
  auto started = running.get_future();
  loop_->post([&running] { running.set_value(); });
  thread_ = std::thread([this] {
    // Named after its loop (at most 15 characters), for top -H, perf and gdb.
    (void)::pthread_setname_np(::pthread_self(), loop_->name().substr(0, 15).c_str());
    loop_->run();
  });
  started.wait();
}

void LoopThread::stop() noexcept {
  if (!thread_.joinable()) return;
  loop_->stop();
  thread_.join();
}

}  // namespace skr
