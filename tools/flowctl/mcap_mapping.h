// SPDX-License-Identifier: Apache-2.0
// How flowctl record and play map the hub's channels to MCAP and back (docs/recording.md).
#pragma once

#include <skrobot/mcap/records.h>
#include <skrobot/runtime/flow/variant.h>
#include <skrobot/channel_type.hpp>

#include <string>
#include <string_view>

namespace flowctl::mcapmap {

// A metadata record of this name holds one channel's properties from `log_time` on:
//   "channel": the recorded channel's name, "log_time": ns since the epoch (decimal),
//   "properties": the channel's whole property map as JSON (Variant JSON: typed).
inline constexpr std::string_view kPropertiesName = "skrobot.channel_properties";
// The header's profile and library.
inline constexpr std::string_view kProfile = "";
inline constexpr std::string_view kLibrary = "skrobot flowctl";
// Channel metadata keys.
inline constexpr std::string_view kMimeKey = "mime";
inline constexpr std::string_view kOwnerKey = "owner";

// JSON mime types become message encoding "json"; other channels keep their mime type (or
// application/octet-stream when they have none).
inline bool isJsonMime(std::string_view mime) {
  return mime == "application/json" || mime == "text/json" || mime.ends_with("+json");
}
inline std::string encodingForMime(std::string_view mime) {
  if (isJsonMime(mime)) return "json";
  return mime.empty() ? std::string("application/octet-stream") : std::string(mime);
}
// The mime type to re-create a recorded channel with.
inline std::string mimeOf(const skr::mcap::Channel& c) {
  if (auto it = c.metadata.find(std::string(kMimeKey)); it != c.metadata.end()) return it->second;
  if (c.message_encoding == "json") return "application/json";
  return c.message_encoding;
}

// The type a channel's properties declare (docs/channels.md, "Typed channels"); empty strings for
// what they leave out or give as other than text.
inline skr::channel_type::ChannelType typeOf(const skr::flow::Variant& props) {
  namespace ct = skr::channel_type;
  auto text = [&](std::string_view key) {
    const skr::flow::Variant* v = props.isMap() ? props.find(std::string(key)) : nullptr;
    return v != nullptr && v->asString() != nullptr ? *v->asString() : std::string();
  };
  return {text(ct::kMessageEncodingKey), text(ct::kSchemaNameKey), text(ct::kSchemaEncodingKey),
          text(ct::kSchemaKey)};
}

// A typed channel is recorded with its own message encoding and schema (MCAP's words are the
// hub's); media frames and untyped channels as the mime type says. ROS 2 channels (cdr with a
// ros2msg schema) follow MCAP's ROS 2 profile that way.
inline bool recordedAsTyped(const skr::channel_type::ChannelType& t) {
  return !t.message_encoding.empty() && t.message_encoding != "skrobot.media" &&
         !skr::channel_type::check(t);
}

}  // namespace flowctl::mcapmap
