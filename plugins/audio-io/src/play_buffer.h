// SPDX-License-Identifier: Apache-2.0
// Samples waiting to be played: filled by the loop thread from the played channel, drained by
// the device thread. Bounded: when full the oldest samples are dropped (and counted), so a
// stalled device never holds the loop thread up.
#pragma once

#include <cstdint>
#include <deque>
#include <mutex>
#include <vector>

namespace skr::audio {

class PlayBuffer {
 public:
  explicit PlayBuffer(std::size_t max_samples) : max_(max_samples) {}

  // Loop thread. A new rate or channel count clears what is left of the old format.
  void push(const std::vector<std::int16_t>& samples, std::uint32_t rate, std::uint16_t channels);
  // Device thread: up to `max` samples of one format into `out`; the format in rate/channels.
  std::size_t pop(std::vector<std::int16_t>& out, std::size_t max, std::uint32_t& rate,
                  std::uint16_t& channels);
  [[nodiscard]] std::uint64_t dropped() const;

 private:
  mutable std::mutex mutex_;
  std::deque<std::int16_t> samples_;
  std::uint32_t rate_ = 0;
  std::uint16_t channels_ = 0;
  std::size_t max_;
  std::uint64_t dropped_ = 0;
};

}  // namespace skr::audio
