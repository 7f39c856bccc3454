// SPDX-License-Identifier: Apache-2.0
// SUBSCRIBE_RATE's caps (1.14) for one connection: at most max_hz data frames a second of each
// capped channel, newest wins. A frame that comes within the interval after the last one sent
// waits, replacing (skipping) the one waiting before it; it goes when the interval ends, from a
// loop timer armed only while a frame waits. So a channel that falls still ends on its newest
// frame. Loop thread only.
#pragma once

#include <skrobot/runtime/clock.h>
#include <skrobot/runtime/loop_handles.h>

#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <string_view>

namespace skr::flow {

class RateCaps {
 public:
  // `deliver` gets a waiting frame when its interval ends.
  RateCaps(Loop& loop, std::function<void(uint16_t chan, std::string_view payload)> deliver);

  // Caps channel `chan` at `max_hz` frames a second (0: no cap; a frame waiting goes at once).
  void set(uint16_t chan, uint16_t max_hz);
  // The subscription ended: its cap goes, and the frame waiting with it.
  void remove(uint16_t chan) noexcept;
  // Whether a frame of `chan` arriving at `now` goes now (true: counted as sent); false: it waits.
  [[nodiscard]] bool admit(uint16_t chan, std::string_view payload, Nanos now);
  [[nodiscard]] bool empty() const noexcept { return caps_.empty(); }

  struct Info {
    uint16_t max_hz = 0;   // 0: not capped
    uint64_t skipped = 0;  // frames replaced by a newer one before they could go
  };
  [[nodiscard]] Info info(uint16_t chan) const noexcept;

 private:
  struct Cap {
    uint16_t max_hz = 0;
    Nanos interval = 0;
    Nanos last = 0;  // when the last frame went (0: none yet)
    bool waiting = false;
    std::string payload;  // the waiting frame
    uint64_t skipped = 0;
  };
  void arm();
  void fire();

  std::function<void(uint16_t, std::string_view)> deliver_;
  std::map<uint16_t, Cap> caps_;
  Timer timer_;
};

}  // namespace skr::flow
