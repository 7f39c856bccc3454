// SPDX-License-Identifier: Apache-2.0
// A media channel's properties as JSON: the vocabulary of media_frame.hpp (message_encoding,
// encoding) and the older keys derived from it (docs/channels.md "Vocabulary"). Every producer of
// media frames writes its channel's database with this, beside its numbers (width, height, fps,
// sample_rate, channels), and creates the channel with the encoding's mime type.
#pragma once

#include <skrobot/media_frame.hpp>

#include <json/value.h>

#include <string>

namespace skr::support {

inline void addMediaProperties(Json::Value& props, const media::EncodingInfo& e) {
  for (const auto& p : media::channelProperties(e)) {
    props[std::string(p.key)] = std::string(p.value);
  }
}

}  // namespace skr::support
