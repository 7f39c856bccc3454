// SPDX-License-Identifier: Apache-2.0
#include "rate_caps.h"

#include <vector>

namespace skr::flow {

RateCaps::RateCaps(Loop& loop, std::function<void(uint16_t, std::string_view)> deliver)
    : deliver_(std::move(deliver)), timer_(loop, [this] { fire(); }) {}

void RateCaps::set(uint16_t chan, uint16_t max_hz) {
  if (max_hz == 0) {
    const auto it = caps_.find(chan);
    if (it == caps_.end()) return;
    std::string payload = std::move(it->second.payload);
    const bool waiting = it->second.waiting;
    caps_.erase(it);
    arm();
    if (waiting) deliver_(chan, payload);
    return;
  }
  Cap& cap = caps_[chan];
  cap.max_hz = max_hz;
  cap.interval = kNsPerSec / max_hz;
  arm();  // a frame waiting goes at the end of the new interval
}

void RateCaps::remove(uint16_t chan) noexcept {
  if (caps_.erase(chan) != 0) arm();
}

bool RateCaps::admit(uint16_t chan, std::string_view payload, Nanos now) {
  const auto it = caps_.find(chan);
  if (it == caps_.end()) return true;
  Cap& cap = it->second;
  if (!cap.waiting && (cap.last == 0 || now - cap.last >= cap.interval)) {
    cap.last = now;
    return true;
  }
  if (cap.waiting) {
    ++cap.skipped;
  } else {
    cap.waiting = true;
    if (!timer_.active() || timer_.deadline() > cap.last + cap.interval) {
      timer_.startAt(cap.last + cap.interval);
    }
  }
  cap.payload.assign(payload.data(), payload.size());
  return false;
}

RateCaps::Info RateCaps::info(uint16_t chan) const noexcept {
  const auto it = caps_.find(chan);
  if (it == caps_.end()) return {};
  return {it->second.max_hz, it->second.skipped};
}

void RateCaps::arm() {
  Nanos next = 0;
  for (const auto& [chan, cap] : caps_) {
    if (cap.waiting && (next == 0 || cap.last + cap.interval < next))
      next = cap.last + cap.interval;
  }
  if (next == 0) {
    timer_.stop();
  } else {
    timer_.startAt(next);
  }
}

void RateCaps::fire() {
  const Nanos now = monotonicNs();
  std::vector<std::pair<uint16_t, std::string>> due;
  for (auto& [chan, cap] : caps_) {
    if (!cap.waiting || cap.last + cap.interval > now) continue;
    cap.waiting = false;
    cap.last = now;
    due.emplace_back(chan, std::move(cap.payload));
    cap.payload.clear();
  }
  arm();
  // After the bookkeeping: only then is a frame handed on.
  for (const auto& [chan, payload] : due) deliver_(chan, payload);
}

}  // namespace skr::flow
