// SPDX-License-Identifier: Apache-2.0
// Polling for a condition in tests that cannot be told when something happened.
#pragma once

#include <chrono>
#include <functional>
#include <thread>

namespace skr::test {

// Polls `done` every 10 ms for up to timeout_ms (generous: CI machines are slow).
inline bool eventually(const std::function<bool()>& done, int timeout_ms = 20000) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
  while (std::chrono::steady_clock::now() < end) {
    if (done()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return done();
}

}  // namespace skr::test
