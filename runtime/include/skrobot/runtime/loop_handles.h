// SPDX-License-Identifier: Apache-2.0
// Handles on a Loop for what its users would otherwise reach libuv for: timers, a function run on
// every turn of the loop, the readiness of a file descriptor, and POSIX signals (SIGINT, SIGTERM:
// not skr::Signal, which is signal/slot). Each is a small RAII object owned by its caller.
//
// What every handle here promises:
// - Thread: create, start and stop it on its loop's thread, or before the loop first runs.
//   Creating or starting one from another thread once the loop is bound aborts, as
//   Loop::addTickHandler does (Loop::requireLoopThread). Destroy it on the loop's thread, or once
//   the loop's run* call has returned.
// - Lifetime: the loop must outlive its handles. The handle owns its callback (and the captures).
// - Callbacks run on the loop thread, from the loop itself: never inside start() or stop(). An
//   exception that escapes a callback is logged (LOOP-EXCEPTION) and the loop goes on.
// - Stop and destruction are final: once stop() returned, or the handle was destroyed (or
//   move-assigned over), its callback is not called again, even for an event that already came in
//   the same turn of the loop. A callback may stop, restart or destroy its own handle: the callback
//   and its captures live until it returns (libuv frees the handle at the loop's next turn).
// - Moves are noexcept and keep a started handle running. A moved-from or default-constructed
//   handle is empty: it watches nothing, stop() on it does nothing, and starting it is a
//   contract violation (it aborts).
#pragma once

#include <skrobot/runtime/clock.h>
#include <skrobot/runtime/loop.h>
#include <skrobot/runtime/result.h>

#include <functional>

namespace skr {

// Calls a function once at a deadline, or periodically from absolute deadlines. Deadlines are
// monotonicNs() values; a timer never fires before its deadline (libuv counts whole
// milliseconds: it fires up to about a millisecond after it, more when the loop is busy).
class Timer {
 public:
  Timer() noexcept = default;
  Timer(Loop& loop, std::function<void()> on_fire);
  ~Timer();
  Timer(const Timer&) = delete;
  Timer& operator=(const Timer&) = delete;
  Timer(Timer&& other) noexcept;
  Timer& operator=(Timer&& other) noexcept;

  // Each start replaces the previous one (a pending firing is forgotten).
  // Fires once at `deadline_ns`; a deadline already past fires at the loop's next turn.
  void startAt(Nanos deadline_ns);
  // Fires once `delay_ns` from now.
  void startIn(Nanos delay_ns);
  // Fires every `period_ns` (> 0), first at `first_deadline_ns` (0: one period from now). The
  // next deadline is the last one plus the period, so late firings do not drift; periods missed
  // entirely (the loop was held up) are skipped, never fired in a burst.
  void startEvery(Nanos period_ns, Nanos first_deadline_ns = 0);
  void stop() noexcept;

  // Started and not fired yet (once) or not stopped (periodic).
  [[nodiscard]] bool active() const noexcept;
  // The next deadline while active(), else 0.
  [[nodiscard]] Nanos deadline() const noexcept;
  explicit operator bool() const noexcept { return state_ != nullptr; }

 private:
  struct State;
  void arm(Nanos deadline_ns, Nanos period_ns);
  State* state_ = nullptr;
};

// Runs a function on every turn of the loop while started. The loop then polls for I/O without
// sleeping: it spins, costing a core. For short spells of polling what cannot wake the loop (a
// shared-memory ring read while a stream lasts); a tick handler does for periodic work.
class Spinner {
 public:
  Spinner() noexcept = default;
  Spinner(Loop& loop, std::function<void()> on_turn);
  ~Spinner();
  Spinner(const Spinner&) = delete;
  Spinner& operator=(const Spinner&) = delete;
  Spinner(Spinner&& other) noexcept;
  Spinner& operator=(Spinner&& other) noexcept;

  void start();  // idempotent
  void stop() noexcept;
  [[nodiscard]] bool active() const noexcept;
  explicit operator bool() const noexcept { return state_ != nullptr; }

 private:
  struct State;
  State* state_ = nullptr;
};

// Readiness of a descriptor that is not a libuv stream (a raw socket, an eventfd, a pipe): the
// callback gets the events that came, as bits.
class FdWatch {
 public:
  enum Event : unsigned {
    readable = 1,  // data to read, a connection to accept, or the end of the stream
    writable = 2,  // room to write; a non-blocking connect finished (SO_ERROR says how)
    hangup = 4,    // the peer shut its side down (what it sent before may still be read)
    error = 8,     // callback only: polling failed (the descriptor broke); the watch has stopped
  };

  FdWatch() noexcept = default;
  // Watches `fd`, which stays the caller's: destroy the watch before closing it. libuv makes the
  // descriptor non-blocking. Nothing is waited for until watch(). Errc::io_error (libuv's reason)
  // when the descriptor cannot be polled: a regular file, a closed descriptor, or one that
  // another FdWatch on this loop watches already.
  [[nodiscard]] static Result<FdWatch> open(Loop& loop, int fd,
                                            std::function<void(unsigned events)> on_events);
  ~FdWatch();
  FdWatch(const FdWatch&) = delete;
  FdWatch& operator=(const FdWatch&) = delete;
  FdWatch(FdWatch&& other) noexcept;
  FdWatch& operator=(FdWatch&& other) noexcept;

  // Waits for `events` (readable | writable | hangup), replacing what it waited for; 0 stops.
  // Costs nothing when they are the ones waited for already (a publisher calls it per message).
  void watch(unsigned events);
  void stop() noexcept;
  // What it waits for now (0 after stop(), and after an `error` event).
  [[nodiscard]] unsigned watching() const noexcept;
  [[nodiscard]] int fd() const noexcept;
  explicit operator bool() const noexcept { return state_ != nullptr; }

 private:
  struct State;
  explicit FdWatch(State* state) noexcept : state_(state) {}
  State* state_ = nullptr;
};

// Calls a function on the loop thread, never in signal context, each time the process gets a
// POSIX signal (several arrivals before the loop's next turn may be reported once). While a
// watch for a signal exists anywhere in the process, the signal does not take its default
// action; when the last one goes, the default action is back.
class SignalWatch {
 public:
  SignalWatch() noexcept = default;
  // Errc::invalid_argument for a signal that cannot be caught (SIGKILL, SIGSTOP, not a signal);
  // Errc::io_error when libuv cannot set it up (out of descriptors).
  [[nodiscard]] static Result<SignalWatch> open(Loop& loop, int signum,
                                                std::function<void(int signum)> on_signal);
  ~SignalWatch();
  SignalWatch(const SignalWatch&) = delete;
  SignalWatch& operator=(const SignalWatch&) = delete;
  SignalWatch(SignalWatch&& other) noexcept;
  SignalWatch& operator=(SignalWatch&& other) noexcept;

  void stop() noexcept;                       // as destruction, but keeps the (empty) object
  [[nodiscard]] int signum() const noexcept;  // 0 once stopped
  explicit operator bool() const noexcept { return state_ != nullptr; }

 private:
  struct State;
  explicit SignalWatch(State* state) noexcept : state_(state) {}
  State* state_ = nullptr;
};

// SIGINT and SIGTERM stop a loop (Loop::stop: its run* returns after the current callback) for as
// long as this object lives: a program's clean exit on Ctrl-C or on its service manager's stop.
// Made by stopOnSignals().
class StopOnSignals {
 public:
  StopOnSignals() noexcept = default;
  // Both signals are watched (false only where libuv could not set one up). A second signal
  // after the first stopped the loop changes nothing: the program ends on its own way out.
  [[nodiscard]] bool watching() const noexcept { return watches_[0] && watches_[1]; }

 private:
  friend StopOnSignals stopOnSignals(Loop& loop, std::function<void(int signum)> on_signal);
  SignalWatch watches_[2];  // SIGINT, SIGTERM
};

// Loop thread only (or before the loop runs). `on_signal`, when given, runs on the loop thread
// with the signal's number (to log it), right after the loop was told to stop. A signal that
// cannot be watched (libuv out of descriptors) is logged (LOOP-SIGNAL) and left to its default
// action, which ends the process.
[[nodiscard]] StopOnSignals stopOnSignals(Loop& loop,
                                          std::function<void(int signum)> on_signal = {});

}  // namespace skr
