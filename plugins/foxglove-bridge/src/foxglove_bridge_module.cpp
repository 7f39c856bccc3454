// SPDX-License-Identifier: Apache-2.0
// foxglove-bridge: the hub's channels, services and databases for Foxglove Studio and
// Lichtblick over foxglove.websocket.v1 (docs/foxglove.md).
//
// Threads: libwebsockets runs on the WsServer's thread, where client messages are decoded (a
// malformed one closes that client there) and handed to the hub's loop thread with host.post;
// channels, subscriptions, requests and databases are touched on the loop thread only. Camera
// frames, annotations and joints are converted on a ConvertWorker thread (newest wins per
// channel), which sends them itself (WsServer::send may be called from any thread); JSON and
// typed messages go through it too, in order (JSON ones checked to parse). A hub
// channel is subscribed only while some client subscribes to it. A channel's schema follows its
// `encoding` property (a database watch per channel whose schema it decides).
#include "convert_worker.h"
#include "foxglove_convert.h"
#include "foxglove_protocol.h"

#include <skrobot/web/ws_server.h>
#include <skrobot/channel_type.hpp>
#include <skrobot/media_frame.hpp>
#include <skrobot/plugin_channels.hpp>
#include <skrobot/plugin_watch.hpp>
#include <skrobot/support/config.hpp>
#include <skrobot/support/json.hpp>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

namespace skr::foxglove {
namespace {

using skr::plugin::Failure;
using skr::support::writeJson;

constexpr int kCloseUnsupportedData = 1003;
constexpr int kCloseInvalidPayload = 1007;
constexpr int kCloseTooBig = 1009;
// What one client may hold (each message's lists are limited by DecodeLimits, these across
// messages): subscriptions, and parameter names it follows.
constexpr std::size_t kMaxSubscriptions = 4096;
constexpr std::size_t kMaxParameterSubscriptions = 4096;
// What a JSON channel's message may be to be forwarded (the hub's own limit on a message is 64
// MiB).
constexpr skr::support::JsonLimits kChannelJsonLimits{256, 64u << 20};

std::uint64_t wallNs() {
  return static_cast<std::uint64_t>(std::chrono::duration_cast<std::chrono::nanoseconds>(
                                        std::chrono::system_clock::now().time_since_epoch())
                                        .count());
}

std::set<std::string> stringSet(const skr::plugin::Host& host, const char* key) {
  std::set<std::string> out;
  auto config = skr::support::parseJsonObject(host.configJson());
  if (!config) return out;
  for (const Json::Value& v : (*config)[key]) {
    if (!v.isString()) {
      host.configError(key, "must be a list of strings");
      throw Failure(SKR_ERR_CONFIG, std::string(key) + " must be a list of strings");
    }
    out.insert(v.asString());
  }
  return out;
}

struct Client {
  std::map<std::uint32_t, std::uint32_t> subs;  // subscription id -> channel id
  std::set<std::string> param_subs;             // parameter names
  bool graph = false;                           // subscribed to the connection graph
  bool graph_sent = false;                      // has had the whole graph once
};

struct Chan {
  std::uint32_t id = 0;
  std::string name;
  std::string mime;
  Shape shape = Shape::json;
  skr::channel_type::ChannelType type;   // Shape::typed: what the channel declares
  std::vector<std::string> joint_names;  // Shape::joints: the channel's "names" property
  std::size_t subscribers = 0;           // client subscriptions over all clients
  skr::plugin::Subscription sub;         // held while subscribers > 0
};

class FoxgloveBridge final : public skr::plugin::Module {
 public:
  explicit FoxgloveBridge(skr::plugin::Host& host) : host_(host) {
    opts_.address = host.configString("address");
    opts_.port = static_cast<int>(host.configInt("port"));
    opts_.tls_cert = host.configString("tls_cert");
    opts_.tls_key = host.configString("tls_key");
    opts_.max_message_bytes = static_cast<std::size_t>(host.configInt("max_message_bytes"));
    opts_.max_queued_bytes = static_cast<std::size_t>(host.configInt("max_queued_bytes"));
    opts_.serve_files = false;
    opts_.ws_path = "/";
    opts_.subprotocol = kSubprotocol;
    opts_.same_origin_only = host.configBool("same_origin_only");
    opts_.log_tag = "FOXGLOVE";
    opts_.peer_noun = "client";
    limits_.max_json_bytes = opts_.max_message_bytes;
    name_ = host.configString("name");
    inspect_ = host.configString("inspect");
    annotations_ = stringSet(host, "annotations");
    joints_ = stringSet(host, "joints");
    parameter_dbs_ = stringSet(host, "parameters");
  }

  void start() override {
    requester_.emplace(host_);
    watch_ = skr::plugin::ChannelWatch(
        host_, [this](const skr::plugin::ChannelEvent& e) { onChannel(e); });
    for (const auto& db : parameter_dbs_) {
      db_watches_.emplace_back(
          host_, db, [this, db](const std::string& key, const std::optional<std::string>& v) {
            onDbChange(db, key, v);
          });
    }
    session_ = std::to_string(wallNs());
    worker_.start();

    skr::wsui::WsServerEvents events;
    events.log = [this](int level, const std::string& line) {
      const auto space = line.find(' ');
      host_.log.write(static_cast<skr_log_level>(level), line.substr(0, space),
                      space == std::string::npos ? "" : line.substr(space + 1));
    };
    events.opened = [this](std::uint64_t conn, const std::string& peer) {
      host_.post([this, conn, peer] { onOpened(conn, peer); });
    };
    events.closed = [this](std::uint64_t conn, const std::string& why) {
      host_.post([this, conn, why] { onClosed(conn, why); });
    };
    events.message = [this](std::uint64_t conn, bool binary, std::string&& data,
                            int& code) -> std::optional<std::string> {
      auto msg = decodeClientMessage(binary, data, limits_);
      if (!msg) {
        code = msg.error().code == Errc::limit_exceeded ? kCloseTooBig
               : binary                                 ? kCloseUnsupportedData
                                                        : kCloseInvalidPayload;
        return "malformed message: " + msg.error().describe();
      }
      auto shared = std::make_shared<ClientMessage>(std::move(*msg));
      host_.post([this, conn, shared] { onMessage(conn, *shared); });
      return std::nullopt;
    };
    if (auto error = server_.start(opts_, std::move(events))) {
      throw Failure(SKR_ERR_FAILED, *error);
    }
    host_.log.info("FOXGLOVE-LISTENING", "foxglove.websocket.v1 on ",
                   opts_.tls_cert.empty() ? "ws" : "wss", "://", opts_.address, ":", server_.port(),
                   "/");
    second_ = host_.onTick(skr::plugin::Tick::one_sec, [this] { everySecond(); });
  }

  void stop() override {
    worker_.stop();  // before the server: the worker sends
    server_.stop();  // joins the server thread: no more posts from it
    host_.log.info("FOXGLOVE-STOP", counts());
    second_.reset();
    for (auto& [id, c] : chans_) c.sub.reset();
    followed_.clear();
    db_watches_.clear();
    watch_.reset();
    requester_.reset();
  }

 private:
  // --- hub side (loop thread)

  void onChannel(const skr::plugin::ChannelEvent& e) {
    if (e.kind == SKR_CHANNEL_SERVICE) {
      if (e.added) {
        if (services_.count(e.name) != 0) return;
        const std::uint32_t id = next_id_++;
        services_[e.name] = id;
        service_names_[id] = e.name;
        sendAll(advertiseServices({serviceInfo(id, e.name)}));
      } else if (auto it = services_.find(e.name); it != services_.end()) {
        const std::uint32_t id = it->second;
        service_names_.erase(id);
        services_.erase(it);
        sendAll(unadvertiseServices({id}));
      }
      return;
    }
    if (e.kind != SKR_CHANNEL_STREAMING) return;
    if (e.added) {
      if (channel_ids_.count(e.name) != 0 || followed_.count(e.name) != 0) return;
      if (dependsOnProperties(e.name, e.mime)) follow(e.name, e.mime);
      if (auto shape = shapeOf(e.name, e.mime)) advertiseChannel(e.name, e.mime, *shape);
    } else {
      followed_.erase(e.name);  // ends its database watch
      if (auto it = channel_ids_.find(e.name); it != channel_ids_.end()) {
        unadvertiseChannel(it->second);
      }
    }
  }

  // What Foxglove is shown of a streaming channel: nullopt for audio and bytes (nothing it
  // shows from JSON). The config and a JPEG mime decide for good; otherwise the `encoding`
  // property decides (a raw one: foxglove.RawImage), then the mime (JSON).
  std::optional<Shape> shapeOf(const std::string& name, const std::string& mime) const {
    if (annotations_.count(name) != 0) return Shape::annotations;
    if (joints_.count(name) != 0) return Shape::joints;
    if (mime == skr::media::encodingInfo(skr::media::Format::jpeg)->mime) return Shape::image;
    if (rawImageChannel(name)) return Shape::raw_image;
    if (declaredType(name)) return Shape::typed;
    if (mime == "application/json" || mime.ends_with("+json")) return Shape::json;
    return std::nullopt;
  }
  bool dependsOnProperties(const std::string& name, const std::string& mime) const {
    return annotations_.count(name) == 0 && joints_.count(name) == 0 &&
           mime != skr::media::encodingInfo(skr::media::Format::jpeg)->mime;
  }

  void advertiseChannel(const std::string& name, const std::string& mime, Shape shape) {
    const std::uint32_t id = next_id_++;
    Chan& c = chans_[id];
    c.id = id;
    c.name = name;
    c.mime = mime;
    c.shape = shape;
    if (shape == Shape::typed)
      c.type = declaredType(name).value_or(skr::channel_type::ChannelType{});
    channel_ids_[name] = id;
    sendAll(advertise({channelInfo(c)}));
  }

  // Unadvertising ends the clients' subscriptions to the channel (foxglove.websocket.v1: an
  // unadvertised channel's subscriptions are gone) and drops the hub subscription.
  void unadvertiseChannel(std::uint32_t id) {
    auto it = chans_.find(id);
    if (it == chans_.end()) return;
    channel_ids_.erase(it->second.name);
    chans_.erase(it);
    for (auto& [conn, client] : clients_) {
      std::erase_if(client.subs, [id](const auto& s) { return s.second == id; });
    }
    sendAll(unadvertise({id}));
  }

  // Follows the properties of a channel whose shape they decide: a satellite may set them after
  // creating the channel (CHAN_SET_PROPS, or a write to the channel's database).
  void follow(const std::string& name, const std::string& mime) {
    Followed f{mime, {}};
    try {
      f.watch = skr::plugin::DatabaseWatch(
          host_, name, [this, name](const std::string& key, const std::optional<std::string>&) {
            // Told on the loop thread, during the database's change: decided after it.
            namespace ct = skr::channel_type;
            if (key == "encoding" || key.empty() || key == ct::kMessageEncodingKey ||
                key == ct::kSchemaNameKey || key == ct::kSchemaEncodingKey ||
                key == ct::kSchemaKey) {
              host_.post([this, name] { reconsider(name); });
            }
          });
    } catch (const std::exception& e) {
      host_.log.warn("FOXGLOVE-PROPERTIES", "cannot follow the properties of ", name, ": ",
                     e.what(), "; its schema is decided once");
      return;
    }
    followed_.insert_or_assign(name, std::move(f));
  }

  // A followed channel's `encoding` changed: when its shape changed too, it is unadvertised and
  // advertised again under a new id, with its new schema.
  void reconsider(const std::string& name) {
    auto f = followed_.find(name);
    if (f == followed_.end()) return;  // gone meanwhile
    const auto shape = shapeOf(name, f->second.mime);
    const auto old = channel_ids_.find(name);
    const std::optional<Shape> had = old == channel_ids_.end()
                                         ? std::nullopt
                                         : std::optional<Shape>(chans_.at(old->second).shape);
    if (shape == had) return;
    if (old != channel_ids_.end()) unadvertiseChannel(old->second);
    if (shape) advertiseChannel(name, f->second.mime, *shape);
    host_.log.info("FOXGLOVE-READVERTISE", name, ": its properties changed its schema from ",
                   had ? schemaName(*had, f->second.mime) : std::string("none"), " to ",
                   shape ? schemaName(*shape, f->second.mime) : std::string("none"));
  }

  // A channel whose `encoding` property names raw pixels (docs/channels.md): foxglove.RawImage.
  bool rawImageChannel(const std::string& name) const {
    auto encoding = skr::plugin::dbGet(host_, name, "encoding");
    if (!encoding) return false;
    auto parsed = skr::support::parseJson(*encoding);
    return parsed && parsed->isString() && isRawImageEncoding(parsed->asString());
  }

  // A typed channel's declared type (docs/channels.md) when it names a schema and is not media
  // frames (those are shown as images): advertised with its own encoding and schema, so that
  // Foxglove decodes it as it decodes a recording of it (flowctl record).
  std::optional<skr::channel_type::ChannelType> declaredType(const std::string& name) const {
    namespace ct = skr::channel_type;
    auto text = [&](std::string_view key) {
      auto v = skr::plugin::dbGet(host_, name, std::string(key));
      if (!v) return std::string();
      auto parsed = skr::support::parseJson(*v);
      return parsed && parsed->isString() ? parsed->asString() : std::string();
    };
    ct::ChannelType t{text(ct::kMessageEncodingKey), text(ct::kSchemaNameKey),
                      text(ct::kSchemaEncodingKey), text(ct::kSchemaKey)};
    if (t.message_encoding.empty() || t.message_encoding == "skrobot.media" ||
        t.schema_name.empty() || ct::check(t)) {
      return std::nullopt;
    }
    return t;
  }

  ChannelInfo channelInfo(const Chan& c) const {
    if (c.shape == Shape::typed) {
      return ChannelInfo{c.id,
                         c.name,
                         c.type.message_encoding,
                         c.type.schema_name,
                         c.type.schema,
                         c.type.schema_encoding};
    }
    return ChannelInfo{
        c.id, c.name, "json", schemaName(c.shape, c.mime), schemaText(c.shape), "jsonschema"};
  }

  static ServiceInfo serviceInfo(std::uint32_t id, const std::string& name) {
    return ServiceInfo{id, name, "skrobot.ServiceCall",
                       R"({"type":"object","properties":{"command":{"type":"string"},"value":{}},)"
                       R"("required":["command"]})",
                       R"({})"};
  }

  void onData(std::uint32_t id, std::string_view payload) {
    auto it = chans_.find(id);
    if (it == chans_.end()) return;
    Chan& c = it->second;
    std::vector<std::pair<std::uint64_t, std::uint32_t>> to;  // (connection, subscription)
    for (auto& [conn, client] : clients_) {
      for (const auto& [sub, chan] : client.subs) {
        if (chan == id) to.emplace_back(conn, sub);
      }
    }
    if (to.empty()) return;
    if (c.shape == Shape::json || c.shape == Shape::typed) {
      // In order, none dropped while the worker keeps up; a JSON one must parse (Foxglove's
      // decoder would fail on it otherwise).
      auto job = [this, json = c.shape == Shape::json, message = std::string(payload),
                  to = std::move(to)] {
        if (json && !skr::support::parseJson(message, kChannelJsonLimits)) {
          ++skipped_;
          return;
        }
        send(to, Converted{message, 0});
      };
      if (!worker_.submitInOrder(payload.size(), std::move(job))) ++dropped_;
      return;
    }
    auto job = [this, shape = c.shape, name = c.name, joints = c.joint_names,
                message = std::string(payload), to = std::move(to)] {
      std::optional<Converted> out;
      if (shape == Shape::image) out = compressedImage(message, name);
      if (shape == Shape::raw_image) out = rawImage(message, name);
      if (shape == Shape::annotations) out = imageAnnotations(message);
      if (shape == Shape::joints) out = jointPositions(message, joints);
      if (!out) {
        ++skipped_;
        return;
      }
      send(to, *out);
    };
    if (!worker_.submit(id, std::move(job))) ++replaced_;
  }

  // Loop thread or worker.
  void send(const std::vector<std::pair<std::uint64_t, std::uint32_t>>& to, const Converted& out) {
    const std::uint64_t time = out.time_ns != 0 ? out.time_ns : wallNs();
    for (const auto& [conn, sub] : to) {
      server_.send(conn, true, messageData(sub, time, out.json), true);
    }
    ++forwarded_;
  }

  void onDbChange(const std::string& db, const std::string& key,
                  const std::optional<std::string>& value) {
    if (key.empty() && !value) {  // cleared
      std::vector<std::string> gone;
      for (const auto& [name, v] : params_) {
        if (name.starts_with(db + "/")) gone.push_back(name);
      }
      for (const auto& name : gone) setParam(name, std::nullopt);
      return;
    }
    std::optional<Json::Value> v;
    if (value) {
      auto parsed = skr::support::parseJson(*value);
      if (parsed) v = std::move(*parsed);
    }
    setParam(db + "/" + key, v);
  }

  void setParam(const std::string& name, const std::optional<Json::Value>& v) {
    if (v) {
      params_[name] = *v;
    } else {
      params_.erase(name);
    }
    for (auto& [conn, client] : clients_) {
      if (client.param_subs.count(name) != 0) {
        server_.send(conn, false, parameterValues({{name, v ? *v : Json::Value()}}), false);
      }
    }
  }

  // --- client side (loop thread)

  void onOpened(std::uint64_t conn, const std::string& peer) {
    clients_[conn];
    std::vector<std::string> caps = {"parameters", "parametersSubscribe", "services"};
    if (!inspect_.empty()) caps.emplace_back("connectionGraph");
    std::map<std::string, std::string> meta = {{"hub", skr::plugin::hubName(host_)},
                                               {"module", std::string(host_.name())}};
    server_.send(conn, false, serverInfo(name_, caps, meta, session_), false);
    std::vector<ChannelInfo> channels;
    for (const auto& [id, c] : chans_) channels.push_back(channelInfo(c));
    server_.send(conn, false, advertise(channels), false);
    std::vector<ServiceInfo> services;
    for (const auto& [id, name] : service_names_) services.push_back(serviceInfo(id, name));
    server_.send(conn, false, advertiseServices(services), false);
    host_.log.info("FOXGLOVE-CLIENT", "client ", conn, " connected from ", peer);
  }

  void onClosed(std::uint64_t conn, const std::string& why) {
    auto it = clients_.find(conn);
    if (it == clients_.end()) return;
    for (const auto& [sub, chan] : it->second.subs) release(chan);
    clients_.erase(it);
    host_.log.info("FOXGLOVE-CLIENT", "client ", conn, " left: ", why, "; ", counts());
  }

  // What the bridge has done since it started, for the log.
  std::string counts() const {
    return std::to_string(forwarded_.load()) + " messages forwarded, " +
           std::to_string(skipped_.load()) + " that could not be converted skipped, " +
           std::to_string(replaced_.load()) + " replaced by a newer one before conversion, " +
           std::to_string(dropped_.load()) + " dropped with the worker behind";
  }

  void onMessage(std::uint64_t conn, const ClientMessage& msg) {
    auto it = clients_.find(conn);
    if (it == clients_.end()) return;
    Client& client = it->second;
    std::visit([&](const auto& m) { handle(conn, client, m); }, msg);
  }

  void warn(std::uint64_t conn, const std::string& text) {
    server_.send(conn, false, status(StatusLevel::warning, text), false);
  }

  void handle(std::uint64_t conn, Client& client, const Subscribe& m) {
    for (const auto& [sub, chan] : m.subscriptions) {
      if (client.subs.count(sub) != 0) {
        warn(conn, "subscription id " + std::to_string(sub) + " is already in use");
        continue;
      }
      if (client.subs.size() >= kMaxSubscriptions) {
        warn(conn, "over " + std::to_string(kMaxSubscriptions) + " subscriptions");
        break;
      }
      auto c = chans_.find(chan);
      if (c == chans_.end()) {
        warn(conn, "no channel " + std::to_string(chan));
        continue;
      }
      if (!hold(c->second)) {
        warn(conn, "cannot subscribe to " + c->second.name +
                       ": not allowed for the bridge's account (see the hub's log)");
        continue;
      }
      client.subs[sub] = chan;
    }
  }

  void handle(std::uint64_t conn, Client& client, const Unsubscribe& m) {
    for (std::uint32_t sub : m.subscription_ids) {
      auto s = client.subs.find(sub);
      if (s == client.subs.end()) {
        warn(conn, "no subscription " + std::to_string(sub));
        continue;
      }
      const std::uint32_t chan = s->second;
      client.subs.erase(s);
      release(chan);
    }
  }

  void handle(std::uint64_t conn, Client& /*client*/, const GetParameters& m) {
    std::vector<std::pair<std::string, Json::Value>> out;
    if (m.names.empty()) {
      for (const auto& [name, v] : params_) out.emplace_back(name, v);
    } else {
      for (const auto& name : m.names) {
        if (auto p = params_.find(name); p != params_.end()) out.emplace_back(name, p->second);
      }
    }
    server_.send(conn, false, parameterValues(out, m.id), false);
  }

  void handle(std::uint64_t conn, Client& /*client*/, const SetParameters& m) {
    std::vector<std::pair<std::string, Json::Value>> out;
    for (const Parameter& p : m.parameters) {
      const auto slash = p.name.find('/');
      const std::string db = slash == std::string::npos ? "" : p.name.substr(0, slash);
      const std::string key = slash == std::string::npos ? "" : p.name.substr(slash + 1);
      std::string refused;
      if (db.empty() || key.empty()) {
        refused = "is not <database>/<key>";
      } else if (parameter_dbs_.count(db) == 0) {
        refused = "is not in a database this bridge shows";
      } else if (p.value ? !skr::plugin::dbSet(host_, db, key, writeJson(*p.value))
                         : (params_.count(p.name) != 0 && !skr::plugin::dbRemove(host_, db, key))) {
        // The hub checks the module's account (its config entry's "account") and ownership.
        refused = "was refused by the hub (the bridge's account may not write '" + db + "')";
      }
      if (!refused.empty()) {
        ++refused_sets_;
        host_.log.warn("FOXGLOVE-PARAM", "client ", conn, ": set ", p.name, " refused: ", refused);
        server_.send(conn, false,
                     status(StatusLevel::warning, "parameter '" + p.name + "' " + refused), false);
      }
      if (auto v = params_.find(p.name); v != params_.end()) {
        out.emplace_back(p.name, v->second);
      } else {
        out.emplace_back(p.name, Json::Value());
      }
    }
    if (m.id) server_.send(conn, false, parameterValues(out, m.id), false);
  }

  void handle(std::uint64_t conn, Client& client, const ParameterUpdates& m) {
    for (const auto& name : m.names) {
      if (m.subscribe && client.param_subs.size() >= kMaxParameterSubscriptions) {
        warn(conn,
             "over " + std::to_string(kMaxParameterSubscriptions) + " parameter subscriptions");
        break;
      }
      if (m.subscribe) {
        client.param_subs.insert(name);
      } else {
        client.param_subs.erase(name);
      }
    }
  }

  void handle(std::uint64_t conn, Client& client, const ConnectionGraph& m) {
    if (inspect_.empty()) {
      warn(conn, "the connection graph is off (no inspect service configured)");
      return;
    }
    client.graph = m.subscribe;
    client.graph_sent = false;
    if (!m.subscribe) return;
    if (graph_) {
      server_.send(conn, false, connectionGraphUpdate(*graph_, nullptr), false);
      client.graph_sent = true;
    } else {
      inspect();
    }
  }

  void handle(std::uint64_t conn, Client& /*client*/, const ServiceCallRequest& m) {
    auto fail = [&](const std::string& why) {
      server_.send(conn, false, serviceCallFailure(m.service_id, m.call_id, why), false);
    };
    auto s = service_names_.find(m.service_id);
    if (s == service_names_.end()) return fail("no service " + std::to_string(m.service_id));
    if (m.encoding != "json") return fail("only the json encoding is supported");
    auto req = skr::support::parseJsonObject(m.data, {limits_.max_depth, limits_.max_json_bytes});
    if (!req || !(*req)["command"].isString()) {
      return fail(R"(the request must be a JSON object {"command": string, "value": any})");
    }
    const std::string command = (*req)["command"].asString();
    const std::string value = req->isMember("value") ? writeJson((*req)["value"]) : "null";
    const std::uint32_t service = m.service_id, call = m.call_id;
    const bool sent = requester_->request(
        s->second, command, value, [this, conn, service, call](bool ok, const std::string& v) {
          if (ok) {
            server_.send(conn, true, serviceCallResponse(service, call, "json", v), false);
          } else {
            server_.send(conn, false, serviceCallFailure(service, call, v), false);
          }
        });
    if (!sent) {
      fail("cannot call " + s->second + ": not running, or not allowed for the bridge's account");
    }
  }

  void handle(std::uint64_t conn, Client& /*client*/, const Unsupported& m) {
    warn(conn, "'" + m.op + "' is not supported by this server");
  }

  // A client subscription to channel `c` is added: the first one subscribes the hub channel.
  // False when the hub refuses (the account's subscribe rule).
  bool hold(Chan& c) {
    if (c.subscribers > 0) {
      ++c.subscribers;
      return true;
    }
    if (c.shape == Shape::joints) {
      c.joint_names.clear();
      if (auto names = skr::plugin::dbGet(host_, c.name, "names")) {
        auto parsed = skr::support::parseJson(*names);
        if (parsed && parsed->isArray()) {
          for (const Json::Value& n : *parsed) c.joint_names.push_back(n.asString());
        }
      }
    }
    const std::uint32_t id = c.id;
    try {
      c.sub = skr::plugin::Subscription(host_, c.name,
                                        [this, id](std::string_view p) { onData(id, p); });
    } catch (const std::exception& e) {
      host_.log.warn("FOXGLOVE-SUBSCRIBE", "cannot subscribe to ", c.name, ": ", e.what());
      return false;
    }
    c.subscribers = 1;
    return true;
  }

  // The last client subscription to channel `id` went: the hub channel is let go.
  void release(std::uint32_t id) {
    auto it = chans_.find(id);
    if (it == chans_.end() || it->second.subscribers == 0) return;
    if (--it->second.subscribers == 0) it->second.sub.reset();
  }

  // --- the connection graph, from the hub's statistics

  bool graphWanted() const {
    return std::any_of(clients_.begin(), clients_.end(),
                       [](const auto& c) { return c.second.graph; });
  }

  void everySecond() {
    if (graphWanted()) inspect();
  }

  void inspect() {
    if (inspecting_ || !requester_) return;
    inspecting_ =
        requester_->request(inspect_, "stats", "{}", [this](bool ok, const std::string& v) {
          inspecting_ = false;
          if (ok) onStats(v);
        });
  }

  void onStats(const std::string& text) {
    auto stats = skr::support::parseJsonObject(text, {16, 64u << 20});
    if (!stats) return;
    std::map<std::int64_t, std::string> flows;
    for (const Json::Value& f : (*stats)["flows"]) {
      flows[f["id"].asInt64()] = f["name"].isString() ? f["name"].asString() : "flow";
    }
    auto flowName = [&](const Json::Value& id) {
      auto it = flows.find(id.asInt64());
      return it != flows.end() ? it->second : "flow " + std::to_string(id.asInt64());
    };
    Graph g;
    for (const Json::Value& c : (*stats)["channels"]) {
      const std::string name = c["name"].asString();
      const std::string kind = c["kind"].asString();
      if (kind == "service") {
        g.services[name].insert(flowName(c["owner_flow"]));
      } else if (kind == "streaming") {
        g.published[name].insert(flowName(c["owner_flow"]));
        auto& subs = g.subscribed[name];
        for (const Json::Value& s : c["subscriber_flows"]) subs.insert(flowName(s));
      }
    }
    const std::optional<Graph> before = std::move(graph_);
    graph_ = std::move(g);
    const bool changed = !before || !(*before == *graph_);
    std::string diff;
    for (auto& [conn, client] : clients_) {
      if (!client.graph) continue;
      if (!client.graph_sent || !before) {
        server_.send(conn, false, connectionGraphUpdate(*graph_, nullptr), false);
        client.graph_sent = true;
      } else if (changed) {
        if (diff.empty()) diff = connectionGraphUpdate(*graph_, &*before);
        server_.send(conn, false, diff, false);
      }
    }
  }

  void sendAll(const std::string& msg) {
    for (const auto& [conn, client] : clients_) server_.send(conn, false, msg, false);
  }

  skr::plugin::Host& host_;
  skr::wsui::WsServerOptions opts_;
  DecodeLimits limits_;
  std::string name_, inspect_, session_;
  std::set<std::string> annotations_, joints_, parameter_dbs_;

  skr::wsui::WsServer server_;
  std::optional<skr::plugin::Requester> requester_;
  skr::plugin::ChannelWatch watch_;
  std::vector<skr::plugin::DatabaseWatch> db_watches_;
  skr::plugin::TickHandle second_;

  // Loop thread only.
  std::uint32_t next_id_ = 1;  // channel and service ids share one counter
  std::map<std::uint32_t, Chan> chans_;
  std::map<std::string, std::uint32_t> channel_ids_;
  // Streaming channels whose properties decide their shape (advertised or not), by name.
  struct Followed {
    std::string mime;
    skr::plugin::DatabaseWatch watch;
  };
  std::map<std::string, Followed> followed_;
  std::map<std::string, std::uint32_t> services_;
  std::map<std::uint32_t, std::string> service_names_;
  std::map<std::uint64_t, Client> clients_;
  std::map<std::string, Json::Value> params_;  // "<db>/<key>" -> value
  std::optional<Graph> graph_;
  bool inspecting_ = false;
  std::uint64_t refused_sets_ = 0;
  // Any thread.
  std::atomic<std::uint64_t> forwarded_ = 0, skipped_ = 0, replaced_ = 0, dropped_ = 0;
  ConvertWorker worker_;  // last: stopped (joined) before the members its jobs use go
};

}  // namespace
}  // namespace skr::foxglove

namespace cfg = skr::config;
constexpr skr_config_key kConfig[] = {
    cfg::string("address", "127.0.0.1", "interface to listen on; \"0.0.0.0\" for every one")
        .nonEmpty(),
    cfg::integer("port", "8765", "WebSocket port (Foxglove's default; 0: any free port)")
        .range(0, 65535),
    cfg::string("tls_cert", "", "PEM certificate; with tls_key: wss:// only"),
    cfg::string("tls_key", "", "PEM private key of tls_cert"),
    cfg::integer("max_message_bytes", "1048576", "largest client message")
        .range(1024, 64 * 1024 * 1024),
    cfg::integer("max_queued_bytes", "16777216",
                 "per-client output queue; beyond it the oldest messages go")
        .min(0),
    cfg::boolean("same_origin_only", "false",
                 "true: refuse clients whose Origin is another site (Foxglove's web app is one)"),
    cfg::string("name", "skrobot", "the server name clients show"),
    cfg::string("inspect", "hub.inspect",
                "the hub's statistics service, for the connection graph (\"\": no graph)"),
    cfg::array("annotations", "[]",
               "detection channels shown as foxglove.ImageAnnotations, e.g. face-detect.faces"),
    cfg::array("joints", "[]", "joint-angle channels shown by joint name, e.g. nao-bridge.joints"),
    cfg::array("parameters", "[]", "databases whose variables are parameters (<db>/<key>)"),
};

SKR_MODULE_WITH_CONFIG(skr::foxglove::FoxgloveBridge, "foxglove-bridge", "1.0.0",
                       "serves channels, services and databases to Foxglove Studio and "
                       "Lichtblick (foxglove.websocket.v1)",
                       0, kConfig)
