// SPDX-License-Identifier: Apache-2.0
// The foxglove.websocket.v1 protocol as foxglove-bridge speaks it (docs/foxglove.md): the
// client messages it reads and the server messages it writes. Pure functions, no I/O; any
// thread. JSON messages are text frames; binary ones start with a one-byte opcode, integers
// little-endian.
#pragma once

#include <skrobot/result.hpp>

#include <json/value.h>

#include <cstddef>
#include <cstdint>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <utility>
#include <variant>
#include <vector>

namespace skr::foxglove {

inline constexpr const char* kSubprotocol = "foxglove.websocket.v1";

// What a client message may hold; anything beyond is refused before it is kept.
struct DecodeLimits {
  std::size_t max_json_bytes = 1u << 20;  // a JSON message's text
  std::size_t max_depth = 16;             // nesting of a JSON message (parameter values)
  std::size_t max_items = 4096;           // entries of one list (subscriptions, names)
  std::size_t max_name_bytes = 1024;      // one parameter name, the service call's encoding
};

// --- client -> server ---
struct Subscribe {
  std::vector<std::pair<std::uint32_t, std::uint32_t>> subscriptions;  // (subscription, channel)
};
struct Unsubscribe {
  std::vector<std::uint32_t> subscription_ids;
};
struct GetParameters {
  std::vector<std::string> names;  // empty: all
  std::optional<std::string> id;
};
struct Parameter {
  std::string name;
  std::optional<Json::Value> value;  // absent: unset the parameter
};
struct SetParameters {
  std::vector<Parameter> parameters;
  std::optional<std::string> id;
};
struct ParameterUpdates {
  bool subscribe = true;
  std::vector<std::string> names;
};
struct ConnectionGraph {
  bool subscribe = true;
};
struct ServiceCallRequest {  // binary opcode 2
  std::uint32_t service_id = 0;
  std::uint32_t call_id = 0;
  std::string encoding;
  std::string data;
};
// A well-formed message this server does not offer (client publishing, assets, unknown ops):
// answered with a status message, the connection stays.
struct Unsupported {
  std::string op;
};

using ClientMessage =
    std::variant<Subscribe, Unsubscribe, GetParameters, SetParameters, ParameterUpdates,
                 ConnectionGraph, ServiceCallRequest, Unsupported>;

// Decodes one complete client message. Errors (the client is then closed): Errc::parse_error
// for bad JSON or a missing or mistyped field, Errc::limit_exceeded past `limits`,
// Errc::protocol_error for a binary message that its lengths do not describe.
[[nodiscard]] Result<ClientMessage> decodeClientMessage(bool binary, std::string_view data,
                                                        const DecodeLimits& limits = {});

// --- server -> client ---
enum class StatusLevel { info = 0, warning = 1, error = 2 };

struct ChannelInfo {
  std::uint32_t id = 0;
  std::string topic;
  std::string encoding;     // "json"
  std::string schema_name;  // "foxglove.CompressedImage", or the hub channel's mime type
  std::string schema;       // JSON schema text
  std::string schema_encoding = "jsonschema";
};

struct ServiceInfo {
  std::uint32_t id = 0;
  std::string name;
  std::string type;
  std::string request_schema;   // JSON schema text of the request
  std::string response_schema;  // and of the response
};

// Topic -> ids of who publishes it (or subscribes, or provides the service).
struct Graph {
  std::map<std::string, std::set<std::string>> published;
  std::map<std::string, std::set<std::string>> subscribed;
  std::map<std::string, std::set<std::string>> services;
  bool operator==(const Graph&) const = default;
};

[[nodiscard]] std::string serverInfo(const std::string& name,
                                     const std::vector<std::string>& capabilities,
                                     const std::map<std::string, std::string>& metadata,
                                     const std::string& session_id);
[[nodiscard]] std::string status(StatusLevel level, const std::string& message,
                                 const std::string& id = {});
[[nodiscard]] std::string advertise(const std::vector<ChannelInfo>& channels);
[[nodiscard]] std::string unadvertise(const std::vector<std::uint32_t>& channel_ids);
[[nodiscard]] std::string advertiseServices(const std::vector<ServiceInfo>& services);
[[nodiscard]] std::string unadvertiseServices(const std::vector<std::uint32_t>& service_ids);
// Binary opcode 1: subscription id, log time (ns since the epoch), the message.
[[nodiscard]] std::string messageData(std::uint32_t subscription_id, std::uint64_t log_time_ns,
                                      std::string_view payload);
// Binary opcode 3.
[[nodiscard]] std::string serviceCallResponse(std::uint32_t service_id, std::uint32_t call_id,
                                              std::string_view encoding, std::string_view data);
[[nodiscard]] std::string serviceCallFailure(std::uint32_t service_id, std::uint32_t call_id,
                                             const std::string& message);
[[nodiscard]] std::string parameterValues(
    const std::vector<std::pair<std::string, Json::Value>>& parameters,
    const std::optional<std::string>& id = std::nullopt);
// The change from `before` to `now`; with `before` null, all of `now` (a new subscriber).
[[nodiscard]] std::string connectionGraphUpdate(const Graph& now, const Graph* before);

}  // namespace skr::foxglove
