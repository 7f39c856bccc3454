// SPDX-License-Identifier: Apache-2.0
// What a browser may send to websocket-ui (docs/websocket-ui.md), checked before anything else
// sees it. Pure functions: no I/O, safe on any thread, fuzzed by websocket_ui_inbound_fuzz.
#pragma once

#include <skrobot/media_frame.hpp>

#include <cstdint>
#include <string>
#include <string_view>
#include <variant>

namespace skr::wsui {

// Close codes of RFC 6455 used for refusals.
inline constexpr int kCloseUnsupported = 1003;  // binary that is not a camera or mic frame
inline constexpr int kCloseBadPayload = 1007;   // text that is not the JSON we expect
inline constexpr int kClosePolicy = 1008;

struct InboundLimits {
  std::uint32_t mic_sample_rate = 22050;
  std::uint16_t max_width = 1920;
  std::uint16_t max_height = 1080;
  std::size_t max_text_bytes = 4096;
  std::size_t max_say_chars = 1000;
};

struct CameraFrame {
  skr::media::FrameHeader header;  // format jpeg, with width and height
  std::string_view jpeg;           // into the message
};
struct MicFrame {
  skr::media::FrameHeader header;  // format pcm_s16le, mono, the configured rate
  std::string_view pcm;
};
struct Hello {
  int version = 0;
  std::string page;
};
struct Say {
  std::string text;
  std::string voice;  // may be empty: the speech module's default
};
struct Refusal {
  int close_code = kClosePolicy;
  std::string reason;
};

using Inbound = std::variant<CameraFrame, MicFrame, Hello, Say, Refusal>;

// Binary messages are media frames (docs/channels.md): JPEG camera frames or mono PCM at the
// configured rate. Text messages are JSON objects with a "type": "hello" or "say" (the network
// page's old "preview", "database" and "set" are refused as unknown: it is a satellite now).
Inbound parseInbound(bool binary, std::string_view message, const InboundLimits& limits);

}  // namespace skr::wsui
