// SPDX-License-Identifier: Apache-2.0
// Failed logins slow down the next ones, per user name and per source (a TCP peer's address, a
// Unix peer's uid), with a delay that doubles with each failure: 0.25 s, 0.5 s, 1 s ... 4 s at
// most (under the default login timeout). A success forgets both; an entry idle for ten minutes
// is forgotten too, and the table is bounded. Main loop thread only.
#pragma once

#include <skrobot/runtime/clock.h>

#include <cstddef>
#include <string>
#include <string_view>
#include <unordered_map>

namespace skr::flow {

class LoginThrottle {
 public:
  static constexpr Nanos kFirstDelay = 250 * kNsPerMs;
  static constexpr Nanos kMaxDelay = 4 * kNsPerSec;
  static constexpr Nanos kForgetAfter = 600 * kNsPerSec;
  static constexpr size_t kMaxEntries = 8192;

  // How long a login of `user` from `source` must wait before it is verified (0: none).
  [[nodiscard]] Nanos wait(std::string_view user, std::string_view source, Nanos now) const;
  void failed(std::string_view user, std::string_view source, Nanos now);
  void succeeded(std::string_view user, std::string_view source);
  [[nodiscard]] size_t size() const noexcept { return entries_.size(); }

 private:
  struct Entry {
    int failures = 0;
    Nanos until = 0;  // no login before this
    Nanos last = 0;   // the last failure
  };
  void fail(const std::string& key, Nanos now);
  void prune(Nanos now);

  std::unordered_map<std::string, Entry> entries_;  // "user:<name>", "from:<source>"
};

}  // namespace skr::flow
