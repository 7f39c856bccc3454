// SPDX-License-Identifier: Apache-2.0
// One browser at a time feeds the camera (or microphone) channel: the browser that owns it keeps
// it while it keeps sending; another takes over once the owner has been silent for `handover_ms`
// or has left. Frames from the others are counted and dropped, so that two open pages do not
// interleave two cameras on one channel. Loop thread only.
#pragma once

#include <cstdint>

namespace skr::wsui {

class SourceOwner {
 public:
  explicit SourceOwner(std::int64_t handover_ms) : handover_ms_(handover_ms) {}

  // True when `conn` may publish now (it owns the source, or takes it over).
  bool accept(std::uint64_t conn, std::int64_t now_ms) {
    if (owner_ != 0 && owner_ != conn && now_ms - last_ms_ <= handover_ms_) {
      ++ignored_;
      return false;
    }
    if (owner_ != conn) {
      owner_ = conn;
      ++takeovers_;
    }
    last_ms_ = now_ms;
    return true;
  }
  // The browser left: whoever sends next takes over at once.
  void leave(std::uint64_t conn) {
    if (owner_ == conn) owner_ = 0;
  }

  [[nodiscard]] std::uint64_t owner() const noexcept { return owner_; }
  [[nodiscard]] std::uint64_t ignored() const noexcept { return ignored_; }
  [[nodiscard]] std::uint64_t takeovers() const noexcept { return takeovers_; }

 private:
  std::int64_t handover_ms_;
  std::uint64_t owner_ = 0;
  std::int64_t last_ms_ = 0;
  std::uint64_t ignored_ = 0;
  std::uint64_t takeovers_ = 0;
};

}  // namespace skr::wsui
