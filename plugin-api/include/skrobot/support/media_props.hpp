// SPDX-License-Identifier: Apache-2.0
// A channel's properties as JSON, in the vocabulary of docs/channels.md. A media channel's: the
// vocabulary of media_frame.hpp (message_encoding, encoding) and the older keys derived from it;
// every producer of media frames writes its channel's database with this, beside its numbers
// (width, height, fps, sample_rate, channels), and creates the channel with the encoding's mime
// type. A typed channel's (channel_type.hpp): message_encoding and its schema.
#pragma once

#include <skrobot/channel_type.hpp>
#include <skrobot/media_frame.hpp>

#include <json/value.h>

#include <stdexcept>
#include <string>

namespace skr::support {

inline void addMediaProperties(Json::Value& props, const media::EncodingInfo& e) {
  for (const auto& p : media::channelProperties(e)) {
    props[std::string(p.key)] = std::string(p.value);
  }
}

// message_encoding and, where it has one, the schema's name, encoding and text. A type that
// channel_type::check refuses is the caller's bug: std::invalid_argument saying why.
inline void addTypeProperties(Json::Value& props, const channel_type::ChannelType& t) {
  if (auto bad = channel_type::check(t)) throw std::invalid_argument("channel type: " + *bad);
  namespace ct = channel_type;
  props[std::string(ct::kMessageEncodingKey)] = t.message_encoding;
  if (t.schema_name.empty()) return;
  props[std::string(ct::kSchemaNameKey)] = t.schema_name;
  props[std::string(ct::kSchemaEncodingKey)] = t.schema_encoding;
  props[std::string(ct::kSchemaKey)] = t.schema;
}

}  // namespace skr::support
