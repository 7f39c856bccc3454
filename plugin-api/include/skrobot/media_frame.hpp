// SPDX-License-Identifier: Apache-2.0
// The media frame header that every video and audio message on a channel starts with, and the
// vocabulary that says what a channel carries (docs/channels.md). Header-only, no dependencies,
// usable by modules, satellites and tests.
//
//   offset size  field
//   0      4     magic "SKMF"
//   4      2     header size in bytes (32; readers skip what they do not know)
//   6      1     format: a code of kEncodings (1 JPEG, 2 mono8, 3 PCM s16le, 4..10 raw pixels)
//   7      1     flags (0; reserved)
//   8      8     seq: video: frame number; audio: index of the first sample since the stream began
//   16     8     capture time, nanoseconds since the Unix epoch (0 when unknown)
//   24     2     video: width  | audio: channels
//   26     2     video: height | audio: 0
//   28     4     video: 0      | audio: sample rate in Hz
//   32     ...   payload: the JPEG file, packed raw pixels (rawPayloadBytes), or interleaved
//   samples
//
// All little-endian. A message shorter than its header, with a wrong magic, a header size under
// 32, an unknown format, or a raw payload that is not exactly rawPayloadBytes(width, height) is
// refused by parseFrame before its payload is touched.
#pragma once

#include <cstdint>
#include <cstring>
#include <optional>
#include <string>
#include <string_view>
#include <utility>

namespace skr::media {

// Format codes of the header's byte 6. y8 is the encoding mono8 (its older name).
enum class Format : std::uint8_t {
  jpeg = 1,
  y8 = 2,
  pcm_s16le = 3,
  rgb8 = 4,
  bgr8 = 5,
  rgba8 = 6,
  bgra8 = 7,
  mono16 = 8,  // little-endian
  nv12 = 9,    // Y plane, then interleaved U,V at half resolution
  i420 = 10,   // Y plane, then U plane, then V plane, each chroma plane at half resolution
};

// The one table of what a channel carries: per format code, the channel property `encoding`
// (ROS sensor_msgs/Image names; `jpeg` compressed; `s16le` audio), the size of a raw payload, and
// the older keys derived from it (docs/channels.md "Vocabulary"). PySketch's copy
// (satellite/python/PySketch/mediacodes.py) is generated from it by tools/flow-catalogue.
struct EncodingInfo {
  Format format;
  std::string_view encoding;      // property `encoding`
  bool video;                     // false: audio
  std::uint8_t bits_per_pixel;    // raw pixels: payload = width*height*bits/8; 0: variable size
  bool even_size;                 // width and height must be even (chroma at half resolution)
  std::string_view mime;          // the channel's mime type
  std::string_view pixel_format;  // older key `pixel_format` (FFmpeg's name; video only)
  std::string_view codec;         // older key `codec` (video only)
  std::string_view flow_type;     // older key `flow_type` (PySketch's Flow_T name)
};

inline constexpr EncodingInfo kEncodings[] = {
    {Format::jpeg, "jpeg", true, 0, false, "image/jpeg", "yuvj420p", "jpeg", "FT_VIDEO_DATA"},
    {Format::y8, "mono8", true, 8, false, "application/octet-stream", "gray", "raw",
     "FT_VIDEO_DATA"},
    {Format::pcm_s16le, "s16le", false, 0, false, "audio/L16", "", "", "FT_AUDIO_DATA"},
    {Format::rgb8, "rgb8", true, 24, false, "application/octet-stream", "rgb24", "raw",
     "FT_VIDEO_DATA"},
    {Format::bgr8, "bgr8", true, 24, false, "application/octet-stream", "bgr24", "raw",
     "FT_VIDEO_DATA"},
    {Format::rgba8, "rgba8", true, 32, false, "application/octet-stream", "rgba", "raw",
     "FT_VIDEO_DATA"},
    {Format::bgra8, "bgra8", true, 32, false, "application/octet-stream", "bgra", "raw",
     "FT_VIDEO_DATA"},
    {Format::mono16, "mono16", true, 16, false, "application/octet-stream", "gray16le", "raw",
     "FT_VIDEO_DATA"},
    {Format::nv12, "nv12", true, 12, true, "application/octet-stream", "nv12", "raw",
     "FT_VIDEO_DATA"},
    {Format::i420, "i420", true, 12, true, "application/octet-stream", "yuv420p", "raw",
     "FT_VIDEO_DATA"},
};

// The property `message_encoding` of a channel of media frames (MCAP's word for what one message
// is).
inline constexpr std::string_view kMessageEncoding = "skrobot.media";

inline constexpr const EncodingInfo* encodingInfo(Format f) {
  for (const auto& e : kEncodings) {
    if (e.format == f) return &e;
  }
  return nullptr;
}
inline constexpr const EncodingInfo* encodingInfo(std::string_view encoding) {
  for (const auto& e : kEncodings) {
    if (e.encoding == encoding) return &e;
  }
  return nullptr;
}
inline constexpr bool isRaw(const EncodingInfo& e) {
  return e.bits_per_pixel != 0;
}

// Bytes of a raw payload of width x height; 0 when `e` is not raw or the size is not allowed
// (zero, or odd for nv12/i420).
inline constexpr std::size_t rawPayloadBytes(const EncodingInfo& e, std::uint16_t width,
                                             std::uint16_t height) {
  if (!isRaw(e) || width == 0 || height == 0) return 0;
  if (e.even_size && (width % 2 != 0 || height % 2 != 0)) return 0;
  return static_cast<std::size_t>(width) * height * e.bits_per_pixel / 8;
}

// A channel property derived from the vocabulary (key, value as a string).
struct Property {
  std::string_view key;
  std::string_view value;
};
// Cap of what channelProperties returns.
inline constexpr std::size_t kMaxDerivedProperties = 7;
struct Properties {
  Property items[kMaxDerivedProperties];
  std::size_t size = 0;
  const Property* begin() const { return items; }
  const Property* end() const { return items + size; }
};

// The string properties of a channel of media frames in `e`: message_encoding and encoding, and
// the older keys derived from them (video: pixel_format, codec; audio: format; both: flow_type,
// data_type), so readers of either vocabulary understand it. Numbers (width, height, fps,
// sample_rate, channels) are the producer's; the mime type is e.mime.
inline constexpr Properties channelProperties(const EncodingInfo& e) {
  Properties p;
  auto add = [&p](std::string_view k, std::string_view v) { p.items[p.size++] = {k, v}; };
  add("message_encoding", kMessageEncoding);
  add("encoding", e.encoding);
  if (e.video) {
    add("pixel_format", e.pixel_format);
    add("codec", e.codec);
  } else {
    add("format", e.encoding);
  }
  add("flow_type", e.flow_type);
  add("data_type", "T_BYTEARRAY");
  return p;
}

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
  const auto* info = encodingInfo(static_cast<Format>(static_cast<std::uint8_t>(msg[6])));
  if (info == nullptr) return std::nullopt;
  f.header.format = info->format;
  f.header.flags = static_cast<std::uint8_t>(msg[7]);
  f.header.seq = detail::get<std::uint64_t>(msg.data() + 8);
  f.header.capture_ns = static_cast<std::int64_t>(detail::get<std::uint64_t>(msg.data() + 16));
  const auto a = detail::get<std::uint16_t>(msg.data() + 24);
  const auto b = detail::get<std::uint16_t>(msg.data() + 26);
  const auto rate = detail::get<std::uint32_t>(msg.data() + 28);
  f.payload = msg.substr(header_bytes);
  if (!info->video) {
    f.header.channels = a;
    f.header.sample_rate = rate;
    if (a == 0 || rate == 0 || f.payload.size() % (2u * a) != 0) return std::nullopt;
    return f;
  }
  f.header.width = a;
  f.header.height = b;
  if (isRaw(*info)) {
    const auto bytes = rawPayloadBytes(*info, a, b);
    if (bytes == 0 || bytes != f.payload.size()) return std::nullopt;
  }
  return f;
}

// A raw video frame of `encoding` (a raw row of kEncodings) from packed pixels; nullopt when the
// encoding is not raw or `pixels` is not exactly rawPayloadBytes(width, height).
inline std::optional<std::string> makeRawFrame(Format encoding, std::uint16_t width,
                                               std::uint16_t height, std::string_view pixels,
                                               std::uint64_t seq = 0, std::int64_t capture_ns = 0) {
  const auto* info = encodingInfo(encoding);
  if (info == nullptr || !isRaw(*info)) return std::nullopt;
  const auto bytes = rawPayloadBytes(*info, width, height);
  if (bytes == 0 || bytes != pixels.size()) return std::nullopt;
  FrameHeader h;
  h.format = encoding;
  h.seq = seq;
  h.capture_ns = capture_ns;
  h.width = width;
  h.height = height;
  return makeFrame(h, pixels);
}

// The width and height a JPEG file declares in its frame header (SOFn), for a JPEG whose size
// its sender did not say; nullopt when `jpeg` does not start as a JPEG, or ends or breaks before
// a frame header. Reads only the markers' lengths, never the entropy-coded data.
inline std::optional<std::pair<std::uint16_t, std::uint16_t>> jpegSize(std::string_view jpeg) {
  auto byte = [&jpeg](std::size_t i) { return static_cast<unsigned char>(jpeg[i]); };
  if (jpeg.size() < 4 || byte(0) != 0xFF || byte(1) != 0xD8) return std::nullopt;
  std::size_t at = 2;
  while (at + 4 <= jpeg.size()) {
    if (byte(at) != 0xFF) return std::nullopt;
    const unsigned marker = byte(at + 1);
    if (marker == 0xFF) {  // fill byte
      ++at;
      continue;
    }
    if (marker == 0x01 || (marker >= 0xD0 && marker <= 0xD7)) {  // no length
      at += 2;
      continue;
    }
    if (marker == 0xD9 || marker == 0xDA) return std::nullopt;  // end, or data before a frame
    const std::size_t length = static_cast<std::size_t>(byte(at + 2)) << 8 | byte(at + 3);
    if (length < 2 || at + 2 + length > jpeg.size()) return std::nullopt;
    const bool sof =
        marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 && marker != 0xC8 && marker != 0xCC;
    if (sof) {
      if (length < 7) return std::nullopt;
      const auto height = static_cast<std::uint16_t>(byte(at + 5) << 8 | byte(at + 6));
      const auto width = static_cast<std::uint16_t>(byte(at + 7) << 8 | byte(at + 8));
      if (width == 0 || height == 0) return std::nullopt;
      return std::pair{width, height};
    }
    at += 2 + length;
  }
  return std::nullopt;
}

// Samples in an audio frame's payload (per channel).
inline std::size_t sampleCount(const Frame& f) {
  return f.header.channels == 0 ? 0 : f.payload.size() / (2u * f.header.channels);
}

}  // namespace skr::media
