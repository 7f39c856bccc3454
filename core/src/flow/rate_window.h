// SPDX-License-Identifier: Apache-2.0
// A channel's or flow's counters sampled at each of the hub's one-second ticks (FlowServer::
// sampleRates), so that its rates over the last second and the last ten are the difference of
// two samples: the same for every reader, and nothing added to the relay's hot path, which only
// counts. The oldest sample is the creation (counters then, usually zero), so a channel younger
// than a window is measured over its age. Main loop thread only.
#pragma once

#include <skrobot/runtime/clock.h>

#include <array>
#include <cstddef>
#include <cstdint>

namespace skr::flow {

template <size_t N>
class RateWindow {
 public:
  static constexpr size_t kLongest = 10;  // samples back: the 10 s window
  using Counters = std::array<uint64_t, N>;

  RateWindow() noexcept = default;
  RateWindow(Nanos created, const Counters& counters) noexcept : created_(created) {
    ring_[0] = Sample{created, counters};
  }

  // At a tick: the counters now. Drops the oldest sample beyond kLongest back.
  void sample(Nanos at, const Counters& counters) noexcept {
    newest_ = static_cast<uint8_t>((newest_ + 1u) % ring_.size());
    ring_[newest_] = Sample{at, counters};
    if (count_ < ring_.size()) ++count_;
  }

  // What the last `samples` intervals saw (or all since the creation when there are fewer):
  // each counter's increase, and the nanoseconds covered (0 before the first tick).
  struct Window {
    Counters delta{};
    Nanos span_ns = 0;
  };
  [[nodiscard]] Window over(size_t samples) const noexcept {
    const size_t older = static_cast<size_t>(count_) - 1;  // samples before the newest
    const size_t back = samples < older ? samples : older;
    const Sample& now = ring_[newest_];
    const Sample& then = ring_[(newest_ + ring_.size() - back) % ring_.size()];
    Window w;
    for (size_t i = 0; i < N; ++i) {
      w.delta[i] = now.counters[i] >= then.counters[i] ? now.counters[i] - then.counters[i] : 0;
    }
    w.span_ns = now.at - then.at;
    return w;
  }
  // From the creation to the newest sample (0 before the first tick).
  [[nodiscard]] Nanos age() const noexcept { return ring_[newest_].at - created_; }

 private:
  struct Sample {
    Nanos at = 0;
    Counters counters{};
  };
  std::array<Sample, kLongest + 1> ring_{};
  Nanos created_ = 0;
  uint8_t newest_ = 0;
  uint8_t count_ = 1;
};

}  // namespace skr::flow
