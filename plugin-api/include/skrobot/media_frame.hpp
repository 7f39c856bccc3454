// SPDX-License-Identifier: Apache-2.0
// The media frame header that every video and audio message on a channel starts with
// (docs/channels.md). Header-only, no dependencies, usable by modules, satellites and tests.
//
//   offset size  field
//   0      4     magic "SKMF"
//   4      2     header size in bytes (32; readers skip what they do not know)
//   6      1     format: 1 JPEG, 2 Y8 (8-bit grey), 3 PCM signed 16-bit little-endian
//   7      1     flags (0; reserved)
//   8      8     seq: video: frame number; audio: index of the first sample since the stream began
//   16     8     capture time, nanoseconds since the Unix epoch (0 when unknown)
//   24     2     video: width  | audio: channels
//   26     2     video: height | audio: 0
//   28     4     video: 0      | audio: sample rate in Hz
//   32     ...   payload: the JPEG file, width*height grey bytes, or interleaved samples
//
// All little-endian. A message shorter than its header, with a wrong magic, a header size under
// 32, or a Y8 payload that does not match width*height is refused by parseMediaFrame.
#pragma once

#include <cstdint>
#include <cstring>
#include <optional>
#include <string>
#include <string_view>

namespace skr::media {

enum class Format : std::uint8_t { jpeg = 1, y8 = 2, pcm_s16le = 3 };

inline constexpr std::size_t kHeaderBytes = 32;
inline constexpr char kMagic[4] = {'S', 'K', 'M', 'F'};

struct FrameHeader {
  Format format = Format::jpeg;
  std::uint8_t flags = 0;
  std::uint64_t seq = 0;
  std::int64_t capture_ns = 0;
  std::uint16_t width = 0;        // video
  std::uint16_t height = 0;       // video
  std::uint16_t channels = 0;     // audio
  std::uint32_t sample_rate = 0;  // audio
};

struct Frame {
  FrameHeader header;
  std::string_view payload;  // points into the parsed message
};

namespace detail {
template <typename T>
inline void put(char* at, T v) {
  for (std::size_t i = 0; i < sizeof(T); ++i) {
    at[i] = static_cast<char>(static_cast<std::uint64_t>(v) >> (8 * i) & 0xff);
  }
}
template <typename T>
inline T get(const char* at) {
  std::uint64_t v = 0;
  for (std::size_t i = 0; i < sizeof(T); ++i) {
    v |= static_cast<std::uint64_t>(static_cast<unsigned char>(at[i])) << (8 * i);
  }
  return static_cast<T>(v);
}
}  // namespace detail

// Writes the 32-byte header into `out` (at least kHeaderBytes).
inline void writeHeader(const FrameHeader& h, char* out) {
  std::memcpy(out, kMagic, 4);
  detail::put<std::uint16_t>(out + 4, kHeaderBytes);
  out[6] = static_cast<char>(h.format);
  out[7] = static_cast<char>(h.flags);
  detail::put<std::uint64_t>(out + 8, h.seq);
  detail::put<std::uint64_t>(out + 16, static_cast<std::uint64_t>(h.capture_ns));
  const bool audio = h.format == Format::pcm_s16le;
  detail::put<std::uint16_t>(out + 24, audio ? h.channels : h.width);
  detail::put<std::uint16_t>(out + 26, audio ? 0 : h.height);
  detail::put<std::uint32_t>(out + 28, audio ? h.sample_rate : 0);
}

// Header + payload as one message.
inline std::string makeFrame(const FrameHeader& h, std::string_view payload) {
  std::string out(kHeaderBytes + payload.size(), '\0');
  writeHeader(h, out.data());
  if (!payload.empty()) std::memcpy(out.data() + kHeaderBytes, payload.data(), payload.size());
  return out;
}

// Parses a message; nullopt when it is not a well-formed media frame (see the top of the file).
inline std::optional<Frame> parseFrame(std::string_view msg) {
  if (msg.size() < kHeaderBytes || std::memcmp(msg.data(), kMagic, 4) != 0) return std::nullopt;
  const auto header_bytes = detail::get<std::uint16_t>(msg.data() + 4);
  if (header_bytes < kHeaderBytes || header_bytes > msg.size()) return std::nullopt;
  Frame f;
  const auto format = static_cast<std::uint8_t>(msg[6]);
  if (format < 1 || format > 3) return std::nullopt;
  f.header.format = static_cast<Format>(format);
  f.header.flags = static_cast<std::uint8_t>(msg[7]);
  f.header.seq = detail::get<std::uint64_t>(msg.data() + 8);
  f.header.capture_ns = static_cast<std::int64_t>(detail::get<std::uint64_t>(msg.data() + 16));
  const auto a = detail::get<std::uint16_t>(msg.data() + 24);
  const auto b = detail::get<std::uint16_t>(msg.data() + 26);
  const auto rate = detail::get<std::uint32_t>(msg.data() + 28);
  f.payload = msg.substr(header_bytes);
  switch (f.header.format) {
    case Format::pcm_s16le:
      f.header.channels = a;
      f.header.sample_rate = rate;
      if (a == 0 || rate == 0 || f.payload.size() % (2u * a) != 0) return std::nullopt;
      break;
    case Format::y8:
      f.header.width = a;
      f.header.height = b;
      if (static_cast<std::size_t>(a) * b != f.payload.size() || a == 0) return std::nullopt;
      break;
    case Format::jpeg:
      f.header.width = a;
      f.header.height = b;
      break;
  }
  return f;
}

// Samples in an audio frame's payload (per channel).
inline std::size_t sampleCount(const Frame& f) {
  return f.header.channels == 0 ? 0 : f.payload.size() / (2u * f.header.channels);
}

}  // namespace skr::media
