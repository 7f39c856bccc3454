// SPDX-License-Identifier: Apache-2.0
#include "foxglove_protocol.h"

#include <skrobot/support/json.hpp>

namespace skr::foxglove {
namespace {

using skr::support::writeJson;

Error bad(const std::string& what) {
  return makeError(Errc::parse_error, what);
}

std::uint32_t readU32(std::string_view data, std::size_t at) {
  std::uint32_t v = 0;
  for (std::size_t i = 0; i < 4; ++i) {
    v |= static_cast<std::uint32_t>(static_cast<unsigned char>(data[at + i])) << (8 * i);
  }
  return v;
}

void putU32(std::string& out, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) out.push_back(static_cast<char>(v >> (8 * i) & 0xff));
}

void putU64(std::string& out, std::uint64_t v) {
  for (int i = 0; i < 8; ++i) out.push_back(static_cast<char>(v >> (8 * i) & 0xff));
}

// A member that must be a list of at most max_items entries.
Result<const Json::Value*> list(const Json::Value& msg, const char* key, const DecodeLimits& lim) {
  const Json::Value* v = msg.find(key, key + std::char_traits<char>::length(key));
  if (v == nullptr || !v->isArray()) return bad(std::string("'") + key + "' must be a list");
  if (v->size() > lim.max_items) {
    return makeError(Errc::limit_exceeded, std::string("'") + key + "' has over " +
                                               std::to_string(lim.max_items) + " entries");
  }
  return v;
}

Result<std::uint32_t> u32(const Json::Value& v, const char* what) {
  if (!v.isUInt() || v.isBool() || !v.isIntegral()) {
    return bad(std::string("'") + what + "' must be an integer in 0..4294967295");
  }
  return static_cast<std::uint32_t>(v.asUInt());
}

Result<std::string> name(const Json::Value& v, const char* what, const DecodeLimits& lim) {
  if (!v.isString()) return bad(std::string("'") + what + "' must be a string");
  std::string s = v.asString();
  if (s.size() > lim.max_name_bytes) {
    return makeError(Errc::limit_exceeded, std::string("'") + what + "' over " +
                                               std::to_string(lim.max_name_bytes) + " bytes");
  }
  return s;
}

Result<std::vector<std::string>> names(const Json::Value& msg, const char* key,
                                       const DecodeLimits& lim) {
  auto l = list(msg, key, lim);
  if (!l) return l.error();
  std::vector<std::string> out;
  for (const Json::Value& v : **l) {
    auto n = name(v, key, lim);
    if (!n) return n.error();
    out.push_back(std::move(*n));
  }
  return out;
}

// The optional request id of getParameters / setParameters.
Result<std::optional<std::string>> requestId(const Json::Value& msg, const DecodeLimits& lim) {
  if (!msg.isMember("id")) return std::optional<std::string>();
  auto n = name(msg["id"], "id", lim);
  if (!n) return n.error();
  return std::optional<std::string>(std::move(*n));
}

Result<ClientMessage> decodeBinary(std::string_view data, const DecodeLimits& lim) {
  if (data.empty()) return makeError(Errc::protocol_error, "empty binary message");
  const auto op = static_cast<unsigned char>(data[0]);
  if (op == 1) return ClientMessage(Unsupported{"client message data (clientPublish)"});
  if (op != 2) {
    return makeError(Errc::protocol_error, "unknown binary opcode " + std::to_string(op));
  }
  // opcode, service id, call id, encoding length, encoding, payload
  if (data.size() < 13) return makeError(Errc::protocol_error, "service call request too short");
  ServiceCallRequest r;
  r.service_id = readU32(data, 1);
  r.call_id = readU32(data, 5);
  const std::uint32_t enc_len = readU32(data, 9);
  if (enc_len > lim.max_name_bytes) {
    return makeError(Errc::limit_exceeded,
                     "service call encoding of " + std::to_string(enc_len) + " bytes");
  }
  if (enc_len > data.size() - 13) {
    return makeError(Errc::protocol_error, "service call encoding length past the message");
  }
  r.encoding.assign(data.substr(13, enc_len));
  r.data.assign(data.substr(13 + enc_len));
  return ClientMessage(std::move(r));
}

}  // namespace

Result<ClientMessage> decodeClientMessage(bool binary, std::string_view data,
                                          const DecodeLimits& lim) {
  if (binary) return decodeBinary(data, lim);
  if (data.size() > lim.max_json_bytes) {
    return makeError(Errc::limit_exceeded,
                     "message over " + std::to_string(lim.max_json_bytes) + " bytes");
  }
  auto parsed = skr::support::parseJsonObject(data, {lim.max_depth, lim.max_json_bytes});
  if (!parsed) return parsed.error();
  const Json::Value& msg = *parsed;
  if (!msg["op"].isString()) return bad("no 'op' string");
  const std::string op = msg["op"].asString();

  if (op == "subscribe") {
    auto l = list(msg, "subscriptions", lim);
    if (!l) return l.error();
    Subscribe s;
    for (const Json::Value& e : **l) {
      if (!e.isObject()) return bad("a subscription must be an object");
      auto id = u32(e["id"], "id");
      if (!id) return id.error();
      auto chan = u32(e["channelId"], "channelId");
      if (!chan) return chan.error();
      s.subscriptions.emplace_back(*id, *chan);
    }
    return ClientMessage(std::move(s));
  }
  if (op == "unsubscribe") {
    auto l = list(msg, "subscriptionIds", lim);
    if (!l) return l.error();
    Unsubscribe u;
    for (const Json::Value& e : **l) {
      auto id = u32(e, "subscriptionIds");
      if (!id) return id.error();
      u.subscription_ids.push_back(*id);
    }
    return ClientMessage(std::move(u));
  }
  if (op == "getParameters") {
    GetParameters g;
    auto n = names(msg, "parameterNames", lim);
    if (!n) return n.error();
    g.names = std::move(*n);
    auto id = requestId(msg, lim);
    if (!id) return id.error();
    g.id = std::move(*id);
    return ClientMessage(std::move(g));
  }
  if (op == "setParameters") {
    auto l = list(msg, "parameters", lim);
    if (!l) return l.error();
    SetParameters s;
    for (const Json::Value& e : **l) {
      if (!e.isObject()) return bad("a parameter must be an object");
      auto n = name(e["name"], "name", lim);
      if (!n) return n.error();
      Parameter p{std::move(*n), std::nullopt};
      if (e.isMember("value") && !e["value"].isNull()) p.value = e["value"];
      s.parameters.push_back(std::move(p));
    }
    auto id = requestId(msg, lim);
    if (!id) return id.error();
    s.id = std::move(*id);
    return ClientMessage(std::move(s));
  }
  if (op == "subscribeParameterUpdates" || op == "unsubscribeParameterUpdates") {
    auto n = names(msg, "parameterNames", lim);
    if (!n) return n.error();
    return ClientMessage(ParameterUpdates{op == "subscribeParameterUpdates", std::move(*n)});
  }
  if (op == "subscribeConnectionGraph") return ClientMessage(ConnectionGraph{true});
  if (op == "unsubscribeConnectionGraph") return ClientMessage(ConnectionGraph{false});
  if (op.size() > lim.max_name_bytes) return bad("'op' too long");
  return ClientMessage(Unsupported{op});
}

std::string serverInfo(const std::string& name, const std::vector<std::string>& capabilities,
                       const std::map<std::string, std::string>& metadata,
                       const std::string& session_id) {
  Json::Value m(Json::objectValue);
  m["op"] = "serverInfo";
  m["name"] = name;
  m["capabilities"] = Json::Value(Json::arrayValue);
  for (const auto& c : capabilities) m["capabilities"].append(c);
  m["supportedEncodings"] = Json::Value(Json::arrayValue);
  m["metadata"] = Json::Value(Json::objectValue);
  for (const auto& [k, v] : metadata) m["metadata"][k] = v;
  m["sessionId"] = session_id;
  return writeJson(m);
}

std::string status(StatusLevel level, const std::string& message, const std::string& id) {
  Json::Value m(Json::objectValue);
  m["op"] = "status";
  m["level"] = static_cast<int>(level);
  m["message"] = message;
  if (!id.empty()) m["id"] = id;
  return writeJson(m);
}

std::string advertise(const std::vector<ChannelInfo>& channels) {
  Json::Value m(Json::objectValue);
  m["op"] = "advertise";
  Json::Value& list = m["channels"] = Json::Value(Json::arrayValue);
  for (const ChannelInfo& c : channels) {
    Json::Value e(Json::objectValue);
    e["id"] = c.id;
    e["topic"] = c.topic;
    e["encoding"] = c.encoding;
    e["schemaName"] = c.schema_name;
    e["schema"] = c.schema;
    e["schemaEncoding"] = c.schema_encoding;
    list.append(std::move(e));
  }
  return writeJson(m);
}

namespace {
std::string idList(const char* op, const char* key, const std::vector<std::uint32_t>& ids) {
  Json::Value m(Json::objectValue);
  m["op"] = op;
  Json::Value& list = m[key] = Json::Value(Json::arrayValue);
  for (std::uint32_t id : ids) list.append(id);
  return writeJson(m);
}

Json::Value schemaDefinition(const std::string& schema) {
  Json::Value d(Json::objectValue);
  d["encoding"] = "json";
  d["schemaName"] = "";
  d["schemaEncoding"] = "jsonschema";
  d["schema"] = schema;
  return d;
}
}  // namespace

std::string unadvertise(const std::vector<std::uint32_t>& channel_ids) {
  return idList("unadvertise", "channelIds", channel_ids);
}

std::string advertiseServices(const std::vector<ServiceInfo>& services) {
  Json::Value m(Json::objectValue);
  m["op"] = "advertiseServices";
  Json::Value& list = m["services"] = Json::Value(Json::arrayValue);
  for (const ServiceInfo& s : services) {
    Json::Value e(Json::objectValue);
    e["id"] = s.id;
    e["name"] = s.name;
    e["type"] = s.type;
    e["request"] = schemaDefinition(s.request_schema);
    e["response"] = schemaDefinition(s.response_schema);
    list.append(std::move(e));
  }
  return writeJson(m);
}

std::string unadvertiseServices(const std::vector<std::uint32_t>& service_ids) {
  return idList("unadvertiseServices", "serviceIds", service_ids);
}

std::string messageData(std::uint32_t subscription_id, std::uint64_t log_time_ns,
                        std::string_view payload) {
  std::string out;
  out.reserve(13 + payload.size());
  out.push_back(1);
  putU32(out, subscription_id);
  putU64(out, log_time_ns);
  out.append(payload);
  return out;
}

std::string serviceCallResponse(std::uint32_t service_id, std::uint32_t call_id,
                                std::string_view encoding, std::string_view data) {
  std::string out;
  out.reserve(13 + encoding.size() + data.size());
  out.push_back(3);
  putU32(out, service_id);
  putU32(out, call_id);
  putU32(out, static_cast<std::uint32_t>(encoding.size()));
  out.append(encoding);
  out.append(data);
  return out;
}

std::string serviceCallFailure(std::uint32_t service_id, std::uint32_t call_id,
                               const std::string& message) {
  Json::Value m(Json::objectValue);
  m["op"] = "serviceCallFailure";
  m["serviceId"] = service_id;
  m["callId"] = call_id;
  m["message"] = message;
  return writeJson(m);
}

std::string parameterValues(const std::vector<std::pair<std::string, Json::Value>>& parameters,
                            const std::optional<std::string>& id) {
  Json::Value m(Json::objectValue);
  m["op"] = "parameterValues";
  Json::Value& list = m["parameters"] = Json::Value(Json::arrayValue);
  for (const auto& [name, value] : parameters) {
    Json::Value p(Json::objectValue);
    p["name"] = name;
    if (!value.isNull()) p["value"] = value;  // absent value: the parameter is unset
    list.append(std::move(p));
  }
  if (id) m["id"] = *id;
  return writeJson(m);
}

std::string connectionGraphUpdate(const Graph& now, const Graph* before) {
  Json::Value m(Json::objectValue);
  m["op"] = "connectionGraphUpdate";
  auto changed = [&](const std::map<std::string, std::set<std::string>>& cur,
                     const std::map<std::string, std::set<std::string>>* old, const char* key,
                     const char* ids_key) {
    Json::Value& list = m[key] = Json::Value(Json::arrayValue);
    for (const auto& [topic, ids] : cur) {
      if (old != nullptr) {
        auto it = old->find(topic);
        if (it != old->end() && it->second == ids) continue;
      }
      Json::Value e(Json::objectValue);
      e["name"] = topic;
      Json::Value& idl = e[ids_key] = Json::Value(Json::arrayValue);
      for (const auto& id : ids) idl.append(id);
      list.append(std::move(e));
    }
  };
  changed(now.published, before ? &before->published : nullptr, "publishedTopics", "publisherIds");
  changed(now.subscribed, before ? &before->subscribed : nullptr, "subscribedTopics",
          "subscriberIds");
  changed(now.services, before ? &before->services : nullptr, "advertisedServices", "providerIds");
  // A topic is removed when nobody publishes or subscribes to it any more.
  Json::Value& removed_topics = m["removedTopics"] = Json::Value(Json::arrayValue);
  Json::Value& removed_services = m["removedServices"] = Json::Value(Json::arrayValue);
  if (before != nullptr) {
    std::set<std::string> was, is;
    for (const auto& [t, _] : before->published) was.insert(t);
    for (const auto& [t, _] : before->subscribed) was.insert(t);
    for (const auto& [t, _] : now.published) is.insert(t);
    for (const auto& [t, _] : now.subscribed) is.insert(t);
    for (const auto& t : was) {
      if (is.count(t) == 0) removed_topics.append(t);
    }
    for (const auto& [s, _] : before->services) {
      if (now.services.count(s) == 0) removed_services.append(s);
    }
  }
  return writeJson(m);
}

}  // namespace skr::foxglove
