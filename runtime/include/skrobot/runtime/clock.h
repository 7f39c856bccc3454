// SPDX-License-Identifier: Apache-2.0
// Monotonic time in nanoseconds, and small helpers.
#pragma once

#include <cstdint>
#include <ctime>
#include <string>

namespace skr {

using Nanos = std::int64_t;

inline Nanos monotonicNs() noexcept {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<Nanos>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

// The wall clock (CLOCK_REALTIME) in nanoseconds since 1970: comparable across machines as far
// as their clocks agree.
inline Nanos realtimeNs() noexcept {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  return static_cast<Nanos>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

// CPU time consumed by the calling thread.
inline Nanos threadCpuNs() noexcept {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<Nanos>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

constexpr Nanos kNsPerMs = 1'000'000;
constexpr Nanos kNsPerSec = 1'000'000'000;

// The wall clock now as ISO 8601 UTC to the second: "2026-11-24T08:15:00Z".
inline std::string utcNowText() {
  const std::time_t now = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&now, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

}  // namespace skr
