// SPDX-License-Identifier: Apache-2.0
// What loop.cpp and loop_handles.cpp share (private to the runtime's sources).
#pragma once

#include <skrobot/runtime/clock.h>
#include <skrobot/runtime/log.h>

#include <uv.h>

#include <cstdint>
#include <exception>
#include <string>

namespace skr::detail {

// Runs fn; an exception must not unwind through libuv's C frames: it is logged (LOOP-EXCEPTION)
// with the loop's name and `what` ran, and the loop goes on.
template <class F>
void runGuarded(const std::string& loop_name, const char* what, F&& fn) {
  try {
    fn();
  } catch (const std::exception& e) {
    log::error("core.loop", "LOOP-EXCEPTION",
               "loop " + loop_name + ": " + what + " threw: " + e.what());
  } catch (...) {
    log::error("core.loop", "LOOP-EXCEPTION", "loop " + loop_name + ": " + what + " threw");
  }
}

// A libuv timer's timeout for `target_ns` (monotonicNs()). libuv counts whole milliseconds from
// its cached loop time: the cache is refreshed and the real time left rounded up (0 when past).
// Rounding the target in loop time instead would add up to 1 ms of truncation error.
inline std::uint64_t uvTimeoutMs(uv_loop_t* uv, Nanos target_ns) {
  uv_update_time(uv);
  const Nanos remaining = target_ns - monotonicNs();
  return remaining <= 0 ? 0 : static_cast<std::uint64_t>((remaining + kNsPerMs - 1) / kNsPerMs);
}

}  // namespace skr::detail
