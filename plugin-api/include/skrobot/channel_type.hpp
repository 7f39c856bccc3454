// SPDX-License-Identifier: Apache-2.0
// What a channel's messages are, said in its properties with MCAP's vocabulary (docs/channels.md,
// "Typed channels"): `message_encoding` says how one message is encoded (`json`, `cdr`, the hub's
// media frames `skrobot.media`, ...); where the encoding has schemas, `schema_name` names the
// message's type ("geometry_msgs/msg/Twist", "skrobot.vision.Faces"), `schema_encoding` says how
// the schema is written (`ros2msg`, `jsonschema`, ...) and `schema` holds its text. A recording
// (flowctl record) and a bridge (ros2-bridge, foxglove-bridge) read them to decode the messages.
// Header-only, no dependencies. tools/flow-catalogue writes the tables out for PySketch
// (mediacodes.py), the JavaScript library (media-codes.js) and docs/channels.md.
#pragma once

#include <optional>
#include <string>
#include <string_view>

namespace skr::channel_type {

// The property keys.
inline constexpr std::string_view kMessageEncodingKey = "message_encoding";
inline constexpr std::string_view kSchemaNameKey = "schema_name";
inline constexpr std::string_view kSchemaEncodingKey = "schema_encoding";
inline constexpr std::string_view kSchemaKey = "schema";

// Whether a message encoding takes a schema.
enum class Schema { none, optional, required };

struct MessageEncoding {
  std::string_view name;              // MCAP's message encoding (its registry's words)
  Schema schema;                      // whether channels of it name a schema
  std::string_view schema_encodings;  // the schema encodings that go with it, '|'-separated
  std::string_view what;              // for the docs
};

inline constexpr MessageEncoding kMessageEncodings[] = {
    {"skrobot.media", Schema::none, "",
     "a media frame (docs/channels.md, \"Media frames\"); `encoding` says which"},
    {"json", Schema::optional, "jsonschema", "UTF-8 JSON text, one value per message"},
    {"cdr", Schema::required, "ros2msg|ros2idl|omgidl",
     "OMG CDR with its 4-byte encapsulation header, as ROS 2 writes it"},
    {"protobuf", Schema::required, "protobuf", "a Protocol Buffers message"},
    {"flatbuffer", Schema::required, "flatbuffer", "a FlatBuffers table"},
    {"cbor", Schema::none, "", "CBOR (RFC 8949)"},
};

inline constexpr const MessageEncoding* messageEncoding(std::string_view name) {
  for (const auto& e : kMessageEncodings) {
    if (e.name == name) return &e;
  }
  return nullptr;
}

// Whether `schema_encoding` is one of `e`'s.
inline constexpr bool takesSchemaEncoding(const MessageEncoding& e, std::string_view encoding) {
  std::string_view rest = e.schema_encodings;
  while (!rest.empty()) {
    const std::size_t bar = rest.find('|');
    if (rest.substr(0, bar) == encoding) return !encoding.empty();
    if (bar == std::string_view::npos) break;
    rest.remove_prefix(bar + 1);
  }
  return false;
}

// A channel's type as its properties say it; empty strings for what they leave out.
struct ChannelType {
  std::string message_encoding;
  std::string schema_name;
  std::string schema_encoding;
  std::string schema;
};

// Why `t` is not a type a channel may declare, or nullopt: an unknown message encoding, a schema
// where the encoding has none, no schema where it needs one, a schema encoding that does not go
// with it, a name without an encoding or the reverse. An empty message_encoding (opaque bytes)
// with no schema is fine.
inline std::optional<std::string> check(const ChannelType& t) {
  const bool any_schema = !t.schema_name.empty() || !t.schema_encoding.empty() || !t.schema.empty();
  if (t.message_encoding.empty()) {
    if (!any_schema) return std::nullopt;
    return std::string("a schema needs a message_encoding");
  }
  const MessageEncoding* e = messageEncoding(t.message_encoding);
  if (e == nullptr) return "unknown message_encoding \"" + t.message_encoding + "\"";
  if (!any_schema) {
    if (e->schema != Schema::required) return std::nullopt;
    return "message_encoding " + t.message_encoding +
           " needs a schema (schema_name, schema_encoding, schema)";
  }
  if (e->schema == Schema::none) {
    return "message_encoding " + t.message_encoding + " takes no schema";
  }
  if (t.schema_name.empty()) return std::string("a schema needs a schema_name");
  if (!takesSchemaEncoding(*e, t.schema_encoding)) {
    return "schema_encoding \"" + t.schema_encoding + "\" does not go with message_encoding " +
           t.message_encoding + " (" + std::string(e->schema_encodings) + ")";
  }
  if (t.schema.empty()) return "schema " + t.schema_name + " has no text (the schema property)";
  return std::nullopt;
}

}  // namespace skr::channel_type
