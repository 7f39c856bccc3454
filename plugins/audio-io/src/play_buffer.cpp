// SPDX-License-Identifier: Apache-2.0
#include "play_buffer.h"

namespace skr::audio {

void PlayBuffer::push(const std::vector<std::int16_t>& samples, std::uint32_t rate,
                      std::uint16_t channels) {
  std::lock_guard lock(mutex_);
  if (rate != rate_ || channels != channels_) {
    samples_.clear();
    rate_ = rate;
    channels_ = channels;
  }
  samples_.insert(samples_.end(), samples.begin(), samples.end());
  const std::size_t cap = max_ - max_ % channels_;  // keep whole frames
  if (samples_.size() > cap) {
    const std::size_t extra = samples_.size() - cap;
    samples_.erase(samples_.begin(), samples_.begin() + static_cast<long>(extra));
    dropped_ += extra / channels_;
  }
}

std::size_t PlayBuffer::pop(std::vector<std::int16_t>& out, std::size_t max, std::uint32_t& rate,
                            std::uint16_t& channels) {
  std::lock_guard lock(mutex_);
  rate = rate_;
  channels = channels_;
  std::size_t n = std::min(max, samples_.size());
  if (channels_ > 0) n -= n % channels_;
  out.assign(samples_.begin(), samples_.begin() + static_cast<long>(n));
  samples_.erase(samples_.begin(), samples_.begin() + static_cast<long>(n));
  return n;
}

std::uint64_t PlayBuffer::dropped() const {
  std::lock_guard lock(mutex_);
  return dropped_;
}

}  // namespace skr::audio
