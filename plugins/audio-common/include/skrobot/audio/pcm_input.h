// SPDX-License-Identifier: Apache-2.0
// Reading PCM media frames (docs/channels.md, format 3) from an audio channel: parse, convert
// the payload to samples, and count malformed frames and gaps in the sample counter.
// Not thread-safe: use one PcmInput on one thread (the module's loop thread).
#pragma once

#include <cstdint>
#include <optional>
#include <string_view>
#include <vector>

namespace skr::audio {

struct PcmChunk {
  std::uint64_t seq = 0;  // index of the first sample (per channel) since the stream began
  std::int64_t capture_ns = 0;
  std::uint32_t sample_rate = 0;
  std::uint16_t channels = 0;
  std::vector<std::int16_t> samples;  // interleaved
  bool discontinuity = false;  // a gap, a rewind or a format change happened before this chunk
  [[nodiscard]] std::size_t frames() const noexcept {
    return channels == 0 ? 0 : samples.size() / channels;
  }
};

struct InputCounters {
  std::uint64_t frames = 0;       // well-formed PCM frames accepted
  std::uint64_t samples = 0;      // samples (per channel) in them
  std::uint64_t malformed = 0;    // refused by parseFrame, or not PCM
  std::uint64_t gaps = 0;         // seq was not the previous seq + its sample count
  std::uint64_t gap_samples = 0;  // samples missing in forward jumps
  std::uint64_t format_changes = 0;
};

class PcmInput {
 public:
  // The chunk in `message`, or nullopt (counted as malformed) when it is not a PCM media frame.
  std::optional<PcmChunk> accept(std::string_view message);
  [[nodiscard]] const InputCounters& counters() const noexcept { return counters_; }

 private:
  InputCounters counters_;
  bool have_prev_ = false;
  std::uint64_t next_seq_ = 0;
  std::uint32_t rate_ = 0;
  std::uint16_t channels_ = 0;
};

// Little-endian s16 bytes to samples, and back.
void decodeS16le(std::string_view bytes, std::vector<std::int16_t>& out);
void encodeS16le(const std::int16_t* samples, std::size_t count, std::string& out);

}  // namespace skr::audio
