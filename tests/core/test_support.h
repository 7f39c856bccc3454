// SPDX-License-Identifier: Apache-2.0
// Helpers shared by the core tests.
#pragma once

#include "log_capture.h"

#include <skrobot/runtime/log.h>
#include <skrobot/runtime/loop.h>

#include <atomic>
#include <mutex>
#include <string>
#include <vector>

namespace skr::test {

// Runs `loop` on the calling thread until everything posted before this call has run.
inline void pump(Loop& loop) {
  std::atomic<bool> done{false};
  loop.post([&done] { done = true; });
  loop.runUntil([&done] { return done.load(); }, 10 * kNsPerSec);
}

}  // namespace skr::test
