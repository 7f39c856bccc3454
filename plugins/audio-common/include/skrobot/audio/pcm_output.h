// SPDX-License-Identifier: Apache-2.0
// Producing PCM media frames on an audio channel: a running sample counter (seq) and the
// channel properties of docs/channels.md.
#pragma once

#include <skrobot/audio/pcm_input.h>

#include <skrobot/media_frame.hpp>
#include <skrobot/support/json.hpp>
#include <skrobot/support/media_props.hpp>

#include <cstdint>
#include <string>

namespace skr::audio {

inline constexpr std::uint32_t kDefaultRate = 22050;

// The mime type of a PCM channel (the s16le row of media::kEncodings).
inline std::string pcmMime() {
  return std::string(media::encodingInfo(media::Format::pcm_s16le)->mime);
}

// {"sample_rate":R,"channels":C,"encoding":"s16le",...}: the database of an audio channel (with
// the older keys derived from the encoding, docs/channels.md).
inline std::string audioProps(std::uint32_t sample_rate, std::uint16_t channels) {
  Json::Value v(Json::objectValue);
  v["sample_rate"] = sample_rate;
  v["channels"] = channels;
  support::addMediaProperties(v, *media::encodingInfo(media::Format::pcm_s16le));
  return support::writeJson(v);
}

// Builds consecutive frames of one stream; seq counts samples (per channel) since the start.
class PcmWriter {
 public:
  PcmWriter(std::uint32_t sample_rate, std::uint16_t channels) noexcept
      : rate_(sample_rate), channels_(channels) {}

  // One frame holding `count` interleaved samples; advances the counter by count / channels.
  std::string frame(const std::int16_t* samples, std::size_t count, std::int64_t capture_ns = 0) {
    media::FrameHeader h;
    h.format = media::Format::pcm_s16le;
    h.seq = next_seq_;
    h.capture_ns = capture_ns;
    h.channels = channels_;
    h.sample_rate = rate_;
    encodeS16le(samples, count, payload_);
    next_seq_ += count / channels_;
    return media::makeFrame(h, payload_);
  }

  [[nodiscard]] std::uint64_t nextSeq() const noexcept { return next_seq_; }
  [[nodiscard]] std::uint32_t sampleRate() const noexcept { return rate_; }
  [[nodiscard]] std::uint16_t channels() const noexcept { return channels_; }
  // A new format keeps the counter running (consumers see a format change, not a gap).
  void setFormat(std::uint32_t sample_rate, std::uint16_t channels) noexcept {
    rate_ = sample_rate;
    channels_ = channels;
  }

 private:
  std::uint32_t rate_;
  std::uint16_t channels_;
  std::uint64_t next_seq_ = 0;
  std::string payload_;
};

}  // namespace skr::audio
