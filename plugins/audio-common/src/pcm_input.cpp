// SPDX-License-Identifier: Apache-2.0
#include <skrobot/audio/pcm_input.h>

#include <skrobot/media_frame.hpp>

namespace skr::audio {

void decodeS16le(std::string_view bytes, std::vector<std::int16_t>& out) {
  const std::size_t n = bytes.size() / 2;
  out.resize(n);
  const auto* p = reinterpret_cast<const unsigned char*>(bytes.data());
  for (std::size_t i = 0; i < n; ++i) {
    out[i] = static_cast<std::int16_t>(static_cast<std::uint16_t>(p[2 * i]) |
                                       static_cast<std::uint16_t>(p[2 * i + 1]) << 8);
  }
}

void encodeS16le(const std::int16_t* samples, std::size_t count, std::string& out) {
  out.resize(count * 2);
  for (std::size_t i = 0; i < count; ++i) {
    const auto v = static_cast<std::uint16_t>(samples[i]);
    out[2 * i] = static_cast<char>(v & 0xff);
    out[2 * i + 1] = static_cast<char>(v >> 8);
  }
}

std::optional<PcmChunk> PcmInput::accept(std::string_view message) {
  const auto frame = media::parseFrame(message);
  if (!frame || frame->header.format != media::Format::pcm_s16le) {
    ++counters_.malformed;
    return std::nullopt;
  }
  PcmChunk c;
  c.seq = frame->header.seq;
  c.capture_ns = frame->header.capture_ns;
  c.sample_rate = frame->header.sample_rate;
  c.channels = frame->header.channels;
  decodeS16le(frame->payload, c.samples);
  const std::uint64_t count = c.frames();

  if (have_prev_) {
    if (c.sample_rate != rate_ || c.channels != channels_) {
      ++counters_.format_changes;
      c.discontinuity = true;
    } else if (c.seq != next_seq_) {
      ++counters_.gaps;
      if (c.seq > next_seq_) counters_.gap_samples += c.seq - next_seq_;
      c.discontinuity = true;
    }
  }
  have_prev_ = true;
  next_seq_ = c.seq + count;
  rate_ = c.sample_rate;
  channels_ = c.channels;
  ++counters_.frames;
  counters_.samples += count;
  return c;
}

}  // namespace skr::audio
