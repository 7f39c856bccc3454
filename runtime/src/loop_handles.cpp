// SPDX-License-Identifier: Apache-2.0
#include <skrobot/runtime/log.h>
#include <skrobot/runtime/loop_handles.h>
#include "loop_internal.h"

#include <uv.h>

#include <algorithm>
#include <csignal>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <utility>

namespace skr {
namespace {

[[noreturn]] void contractViolation(const char* what) noexcept {
  std::fprintf(stderr, "skrobot: %s\n", what);
  std::abort();
}

// Each handle's state (the libuv handle, the callback and its captures) is one heap block that
// libuv frees in the close callback: a callback that destroys its own handle keeps running on
// live memory, and `closed` keeps whatever libuv still delivers in that turn from reaching it.
template <class S>
void closeState(S*& s) noexcept {
  if (s == nullptr) return;
  s->closed = true;
  uv_close(reinterpret_cast<uv_handle_t*>(&s->handle),
           [](uv_handle_t* h) { delete static_cast<S*>(h->data); });
  s = nullptr;
}

template <class S>
S* moveState(S*& into, S*& from) noexcept {
  if (&into != &from) {
    closeState(into);
    into = std::exchange(from, nullptr);
  }
  return into;
}

}  // namespace

// --- Timer ---------------------------------------------------------------------------------------

struct Timer::State {
  uv_timer_t handle{};
  Loop* loop = nullptr;
  std::function<void()> fn;
  Nanos deadline_ns = 0;  // 0: not armed
  Nanos period_ns = 0;    // 0: once
  bool closed = false;

  static void onTimer(uv_timer_t* h);
};

Timer::Timer(Loop& loop, std::function<void()> on_fire) {
  loop.requireLoopThread("Timer::Timer");
  state_ = new State;
  state_->loop = &loop;
  state_->fn = std::move(on_fire);
  state_->handle.data = state_;
  uv_timer_init(loop.uv(), &state_->handle);  // cannot fail
}

Timer::~Timer() {
  closeState(state_);
}

Timer::Timer(Timer&& other) noexcept : state_(std::exchange(other.state_, nullptr)) {}

Timer& Timer::operator=(Timer&& other) noexcept {
  moveState(state_, other.state_);
  return *this;
}

void Timer::arm(Nanos deadline_ns, Nanos period_ns) {
  if (state_ == nullptr) contractViolation("Timer started while empty");
  state_->loop->requireLoopThread("Timer::start");
  // monotonicNs() is never 0 on a running system, but a deadline of 0 means "not armed" here.
  state_->deadline_ns = deadline_ns == 0 ? 1 : deadline_ns;
  state_->period_ns = period_ns;
  uv_loop_t* uv = state_->loop->uv();
  uv_timer_start(&state_->handle, &State::onTimer, detail::uvTimeoutMs(uv, state_->deadline_ns), 0);
}

void Timer::startAt(Nanos deadline_ns) {
  arm(deadline_ns, 0);
}

void Timer::startIn(Nanos delay_ns) {
  arm(monotonicNs() + std::max<Nanos>(delay_ns, 0), 0);
}

void Timer::startEvery(Nanos period_ns, Nanos first_deadline_ns) {
  if (period_ns <= 0) contractViolation("Timer::startEvery with a period <= 0");
  arm(first_deadline_ns != 0 ? first_deadline_ns : monotonicNs() + period_ns, period_ns);
}

void Timer::stop() noexcept {
  if (state_ == nullptr) return;
  state_->deadline_ns = 0;
  uv_timer_stop(&state_->handle);
}

bool Timer::active() const noexcept {
  return state_ != nullptr && state_->deadline_ns != 0;
}

Nanos Timer::deadline() const noexcept {
  return state_ != nullptr ? state_->deadline_ns : 0;
}

void Timer::State::onTimer(uv_timer_t* h) {
  auto* s = static_cast<State*>(h->data);
  if (s->closed || s->deadline_ns == 0) return;
  uv_loop_t* uv = s->loop->uv();
  const Nanos now = monotonicNs();
  if (now < s->deadline_ns) {
    // libuv's millisecond clock ran ahead of ours: wait for the rest (at least 1 ms).
    uv_timer_start(h, &onTimer, std::max<std::uint64_t>(1, detail::uvTimeoutMs(uv, s->deadline_ns)),
                   0);
    return;
  }
  if (s->period_ns > 0) {
    // Armed before the callback runs: it may stop or restart the timer, or destroy it.
    Nanos next = s->deadline_ns + s->period_ns;
    if (next <= now) next += ((now - next) / s->period_ns + 1) * s->period_ns;
    s->deadline_ns = next;
    uv_timer_start(h, &onTimer, detail::uvTimeoutMs(uv, next), 0);
  } else {
    s->deadline_ns = 0;
  }
  detail::runGuarded(s->loop->name(), "timer", s->fn);
}

// --- Spinner -------------------------------------------------------------------------------------

struct Spinner::State {
  uv_idle_t handle{};
  Loop* loop = nullptr;
  std::function<void()> fn;
  bool closed = false;
};

Spinner::Spinner(Loop& loop, std::function<void()> on_turn) {
  loop.requireLoopThread("Spinner::Spinner");
  state_ = new State;
  state_->loop = &loop;
  state_->fn = std::move(on_turn);
  state_->handle.data = state_;
  uv_idle_init(loop.uv(), &state_->handle);  // cannot fail
}

Spinner::~Spinner() {
  closeState(state_);
}

Spinner::Spinner(Spinner&& other) noexcept : state_(std::exchange(other.state_, nullptr)) {}

Spinner& Spinner::operator=(Spinner&& other) noexcept {
  moveState(state_, other.state_);
  return *this;
}

void Spinner::start() {
  if (state_ == nullptr) contractViolation("Spinner started while empty");
  state_->loop->requireLoopThread("Spinner::start");
  uv_idle_start(&state_->handle, [](uv_idle_t* h) {
    auto* s = static_cast<State*>(h->data);
    if (!s->closed) detail::runGuarded(s->loop->name(), "spinner", s->fn);
  });
}

void Spinner::stop() noexcept {
  if (state_ != nullptr) uv_idle_stop(&state_->handle);
}

bool Spinner::active() const noexcept {
  return state_ != nullptr && uv_is_active(reinterpret_cast<const uv_handle_t*>(&state_->handle));
}

// --- FdWatch -------------------------------------------------------------------------------------

struct FdWatch::State {
  uv_poll_t handle{};
  Loop* loop = nullptr;
  int fd = -1;
  std::function<void(unsigned)> fn;
  unsigned events = 0;  // waited for
  bool closed = false;

  static void onPoll(uv_poll_t* h, int status, int uv_events);
};

Result<FdWatch> FdWatch::open(Loop& loop, int fd, std::function<void(unsigned events)> on_events) {
  loop.requireLoopThread("FdWatch::open");
  auto* s = new State;
  s->loop = &loop;
  s->fd = fd;
  s->fn = std::move(on_events);
  s->handle.data = s;
  if (int rc = uv_poll_init(loop.uv(), &s->handle, fd); rc != 0) {
    delete s;  // not registered with the loop when init fails
    return makeError(Errc::io_error,
                     "cannot poll descriptor " + std::to_string(fd) + ": " + uv_strerror(rc));
  }
  return FdWatch(s);
}

FdWatch::~FdWatch() {
  closeState(state_);
}

FdWatch::FdWatch(FdWatch&& other) noexcept : state_(std::exchange(other.state_, nullptr)) {}

FdWatch& FdWatch::operator=(FdWatch&& other) noexcept {
  moveState(state_, other.state_);
  return *this;
}

void FdWatch::watch(unsigned events) {
  if (state_ == nullptr) contractViolation("FdWatch::watch while empty");
  events &= readable | writable | hangup;
  if (events == state_->events) return;
  state_->loop->requireLoopThread("FdWatch::watch");
  state_->events = events;
  if (events == 0) {
    uv_poll_stop(&state_->handle);
    return;
  }
  const int uv_events = ((events & readable) != 0 ? UV_READABLE : 0) |
                        ((events & writable) != 0 ? UV_WRITABLE : 0) |
                        ((events & hangup) != 0 ? UV_DISCONNECT : 0);
  uv_poll_start(&state_->handle, uv_events, &State::onPoll);
}

void FdWatch::stop() noexcept {
  if (state_ == nullptr || state_->events == 0) return;
  state_->events = 0;
  uv_poll_stop(&state_->handle);
}

unsigned FdWatch::watching() const noexcept {
  return state_ != nullptr ? state_->events : 0;
}

int FdWatch::fd() const noexcept {
  return state_ != nullptr ? state_->fd : -1;
}

void FdWatch::State::onPoll(uv_poll_t* h, int status, int uv_events) {
  auto* s = static_cast<State*>(h->data);
  if (s->closed) return;
  unsigned got = 0;
  if (status < 0) {
    got = error;
    s->events = 0;  // libuv stopped the handle
  } else {
    if ((uv_events & UV_READABLE) != 0) got |= readable;
    if ((uv_events & UV_WRITABLE) != 0) got |= writable;
    if ((uv_events & UV_DISCONNECT) != 0) got |= hangup;
  }
  detail::runGuarded(s->loop->name(), "descriptor watch", [s, got] { s->fn(got); });
}

// --- SignalWatch ---------------------------------------------------------------------------------

struct SignalWatch::State {
  uv_signal_t handle{};
  Loop* loop = nullptr;
  std::function<void(int)> fn;
  bool closed = false;
};

Result<SignalWatch> SignalWatch::open(Loop& loop, int signum,
                                      std::function<void(int signum)> on_signal) {
  loop.requireLoopThread("SignalWatch::open");
  auto* s = new State;
  s->loop = &loop;
  s->fn = std::move(on_signal);
  s->handle.data = s;
  const auto failed = [signum](int rc) {
    return makeError(rc == UV_EINVAL ? Errc::invalid_argument : Errc::io_error,
                     "cannot watch signal " + std::to_string(signum) + ": " + uv_strerror(rc));
  };
  if (int rc = uv_signal_init(loop.uv(), &s->handle); rc != 0) {
    delete s;  // not registered with the loop when init fails
    return failed(rc);
  }
  SignalWatch watch(s);  // closes the handle if start fails
  const int rc = uv_signal_start(
      &s->handle,
      [](uv_signal_t* h, int got) {
        auto* st = static_cast<State*>(h->data);
        if (!st->closed)
          detail::runGuarded(st->loop->name(), "signal watch", [st, got] { st->fn(got); });
      },
      signum);
  if (rc != 0) return failed(rc);
  return watch;
}

SignalWatch::~SignalWatch() {
  closeState(state_);
}

SignalWatch::SignalWatch(SignalWatch&& other) noexcept
    : state_(std::exchange(other.state_, nullptr)) {}

SignalWatch& SignalWatch::operator=(SignalWatch&& other) noexcept {
  moveState(state_, other.state_);
  return *this;
}

void SignalWatch::stop() noexcept {
  closeState(state_);
}

int SignalWatch::signum() const noexcept {
  return state_ != nullptr ? state_->handle.signum : 0;
}

StopOnSignals stopOnSignals(Loop& loop, std::function<void(int signum)> on_signal) {
  loop.requireLoopThread("stopOnSignals");
  StopOnSignals out;
  const int signums[2] = {SIGINT, SIGTERM};
  const char* const names[2] = {"SIGINT", "SIGTERM"};
  for (int i = 0; i < 2; ++i) {
    auto watch = SignalWatch::open(loop, signums[i], [&loop, on_signal](int signum) {
      loop.stop();  // first: a throwing on_signal must not keep the loop running
      if (on_signal) on_signal(signum);
    });
    if (!watch) {
      log::warn("core.loop", "LOOP-SIGNAL",
                "loop " + loop.name() + ": " + watch.error().message + "; " + names[i] +
                    " ends the process at once");
      continue;
    }
    out.watches_[i] = std::move(*watch);
  }
  return out;
}

}  // namespace skr
