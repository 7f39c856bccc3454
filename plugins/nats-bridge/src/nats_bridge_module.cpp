// SPDX-License-Identifier: Apache-2.0
// nats-bridge: a hub's channels on a NATS cluster (docs/fleet.md). Exported channels are
// published under the bridge's prefix, imported subjects become channels of the module, services
// cross both ways, named databases are mirrored to JetStream key-value buckets. The NATS client's
// threads never touch the hub: NatsClient queues, the loop drains (drain()).
#include "bridge_config.h"
#include "kv_mirror.h"
#include "nats_client.h"
#include "subject_map.h"

#include <skrobot/plugin.hpp>
#include <skrobot/plugin_channels.hpp>
#include <skrobot/plugin_watch.hpp>
#include <skrobot/support/config.hpp>
#include <skrobot/support/json.hpp>

#include <nats/nats.h>

#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

namespace {

using namespace skr::nats_bridge;
namespace plugin = skr::plugin;
using skr::support::jsonQuote;

// Routes of the NATS subscriptions; imports and exported services take numbers from kFirstRoute.
constexpr uint64_t kReplies = 1;  // answers to the requests of imported services
constexpr uint64_t kProps = 2;    // requests for an exported channel's properties
constexpr uint64_t kFirstRoute = 16;

// JSON text as it came, when it is JSON; otherwise the bytes as a JSON string.
std::string asJson(const std::string& data) {
  if (skr::support::parseJson(data)) return data;
  return jsonQuote(data);
}

// Bridges in this process (a config may load the module more than once, under other names):
// the last one to go frees the C client's process-wide state (nats_CloseAndWait), so that
// unloading the module leaves nothing of it behind.
std::mutex g_library_mutex;
int g_library_users = 0;

class NatsBridge final : public plugin::Module {
 public:
  ~NatsBridge() override {
    std::lock_guard lock(g_library_mutex);
    if (--g_library_users == 0) nats_CloseAndWait(2000);  // its threads are ours alone by now
  }
  explicit NatsBridge(plugin::Host& host) : host_(host) {
    auto config = skr::support::parseJsonObject(host.configJson());
    if (!config) throw plugin::Failure(SKR_ERR_CONFIG, config.error().message);
    const auto problems = readConfig(*config, config_);
    for (const auto& p : problems) host.configError(p.key.c_str(), p.reason);
    if (!problems.empty()) {
      throw plugin::Failure(SKR_ERR_CONFIG, std::to_string(problems.size()) +
                                                " problem(s) in the config (logged above)");
    }
    std::lock_guard lock(g_library_mutex);
    ++g_library_users;  // last: a constructor that throws has no destructor
  }

  void start() override {
    const std::string hub = plugin::hubName(host_);
    prefix_ = config_.prefix.empty() ? "skrobot." + encodeToken(hub, true) : config_.prefix;
    own_prefix_ = std::string(host_.name()) + ".";
    ClientOptions options = config_.client;
    options.name = "skrobot " + hub + " " + std::string(host_.name());
    client_ = std::make_unique<NatsClient>(
        options, [this] { host_.post([this] { drain(); }); },
        [this](NatsClient::Level level, const char* tag, const std::string& text) {
          host_.log.write(level == NatsClient::Level::info   ? SKR_LOG_INFO
                          : level == NatsClient::Level::warn ? SKR_LOG_WARN
                                                             : SKR_LOG_ERROR,
                          tag, text);
        });
    status_ = plugin::StreamChannel(host_, "status", "application/json",
                                    R"({"note": "the bridge's state and counters, every second"})");
    requester_ = std::make_unique<plugin::Requester>(host_);
    client_->subscribe(Lane::prompt, kReplies, client_->inbox() + ".*");
    client_->subscribe(Lane::prompt, kProps, prefix_ + "._props.>");
    for (size_t i = 0; i < config_.imports.size(); ++i) addImport(i);
    for (const KvMirror& m : config_.kv) {
      mirrors_.push_back(std::make_unique<KvMirrorLink>(
          host_, m, [this](KvMirrorLink* link) { host_.post([this, link] { link->drain(); }); }));
    }
    watch_ = plugin::ChannelWatch(host_, [this](const plugin::ChannelEvent& ev) { onChannel(ev); });
    ticks_ = host_.onTick(plugin::Tick::slow, [this] { expireRequests(); });
    status_tick_ = host_.onTick(plugin::Tick::one_sec, [this] { publishStatus(); });
    std::string error;
    if (!client_->start(error)) throw plugin::Failure(SKR_ERR_CONFIG, error);
    for (auto& m : mirrors_) m->start(*client_);
    host_.log.info("NATS-BRIDGE", "prefix ", prefix_, ", ", config_.imports.size(), " import(s), ",
                   config_.kv.size(), " mirrored database(s), servers ",
                   config_.client.servers.front(),
                   config_.client.servers.size() > 1 ? " and others" : "");
  }

  void stop() override {
    watch_.reset();
    for (auto& m : mirrors_) m->stop();
    if (client_) client_->stop();  // no callback or wake after this
    for (const auto& [id, p] : pending_) {
      respondImport(p, R"({"error":"stopped","message":"the bridge stopped"})");
    }
    pending_.clear();
    mirrors_.clear();
    exported_.clear();
    routes_.clear();
    imports_.clear();
    ticks_.reset();
    status_tick_.reset();
    requester_.reset();
    status_ = {};
  }

 private:
  // An imported subject: a streaming channel fed while it has subscribers, or a service channel.
  struct Imported {
    plugin::StreamChannel stream;
    plugin::ServiceChannel service;
  };
  // An exported channel of this hub.
  struct Exported {
    std::string subject;
    skr_channel_kind kind;
    std::string mime;
    uint64_t route = 0;  // services: the NATS subscription taking requests
    plugin::Subscription data;
    plugin::DatabaseWatch props_watch;
    Json::Value props{Json::objectValue};
    bool props_dirty = true;
  };
  // A local request to an imported service, waiting for NATS.
  struct Pending {
    size_t import;
    uint64_t request;
    int64_t deadline_ns;
  };

  void addImport(size_t i) {
    const Import& im = config_.imports[i];
    const uint64_t route = kFirstRoute + i;
    Json::Value props(Json::objectValue);
    props["nats_subject"] = im.subject;
    const std::string props_json = skr::support::writeJson(props);
    Imported entry;
    if (im.service) {
      entry.service = plugin::ServiceChannel(
          host_, im.as, [this, i](const plugin::ServiceRequest& r) { callNats(i, r); }, props_json);
    } else {
      entry.stream =
          plugin::StreamChannel(host_, im.as, im.mime, props_json, [this, route, i](bool first) {
            // Demand: on NATS only while someone here listens.
            if (first) {
              client_->subscribe(Lane::bulk, route, config_.imports[i].subject);
            } else {
              client_->unsubscribe(route);
            }
          });
    }
    imports_.emplace(route, std::move(entry));
  }

  void onChannel(const plugin::ChannelEvent& ev) {
    if (ev.name.rfind(own_prefix_, 0) == 0) return;  // its own: imports are not sent back
    if (!ev.added) {
      auto it = exported_.find(ev.name);
      if (it == exported_.end()) return;
      if (it->second.route != 0) {
        client_->unsubscribe(it->second.route);
        routes_.erase(it->second.route);
      }
      exported_.erase(it);
      return;
    }
    if (!config_.exports.selects(ev.name)) return;
    if (ev.kind != SKR_CHANNEL_STREAMING && ev.kind != SKR_CHANNEL_SERVICE) return;
    Exported& e = exported_[ev.name];
    e.subject = channelSubject(prefix_, ev.name);
    e.kind = ev.kind;
    e.mime = ev.mime;
    if (ev.kind == SKR_CHANNEL_STREAMING) {
      e.data =
          plugin::Subscription(host_, ev.name, [this, subject = e.subject](std::string_view d) {
            client_->publish(Lane::bulk, subject, std::string(d));
          });
    } else {
      e.route = next_route_++;
      routes_[e.route] = ev.name;
      client_->subscribe(Lane::prompt, e.route, e.subject, config_.queue_group);
    }
    const std::string name = ev.name;
    e.props_watch = plugin::DatabaseWatch(
        host_, ev.name, [this, name](const std::string& key, const std::optional<std::string>& v) {
          auto it = exported_.find(name);
          if (it == exported_.end()) return;
          Exported& x = it->second;
          if (key.empty() && !v) {
            x.props = Json::Value(Json::objectValue);
          } else if (!v) {
            x.props.removeMember(key);
          } else if (auto parsed = skr::support::parseJson(*v)) {
            x.props[key] = *parsed;
          }
          x.props_dirty = true;
        });
    host_.log.info("NATS-EXPORT", ev.name, " -> ", e.subject);
  }

  // What NATS handed over since the last drain, on the loop thread.
  void drain() {
    if (!client_) return;
    for (Incoming& in : client_->take()) {
      if (in.route == kReplies) {
        onReply(in);
      } else if (in.route == kProps) {
        onPropsRequest(in);
      } else if (auto im = imports_.find(in.route); im != imports_.end()) {
        im->second.stream.publish(in.data);
      } else if (auto ex = routes_.find(in.route); ex != routes_.end()) {
        onExportedRequest(ex->second, in);
      }
    }
  }

  // --- services: NATS requests to this hub's exported services -------------------------------
  void onExportedRequest(const std::string& channel, const Incoming& in) {
    auto fail = [&](const char* error, const std::string& message) {
      if (!in.reply.empty()) {
        client_->publish(Lane::prompt, in.reply, jsonQuote(message), {}, {}, error);
      }
    };
    const std::string reply = in.reply;
    const std::string& value = in.data.empty() ? std::string("null") : in.data;
    // The hub parses the value once; the bridge looks at it only when the call was refused.
    const bool sent = requester_->request(
        channel, in.command, value, [this, reply](bool ok, const std::string& value_json) {
          if (reply.empty() || !client_) return;
          client_->publish(Lane::prompt, reply, value_json, {}, {}, ok ? "" : "failed");
        });
    if (sent) return;
    uint16_t id = 0;
    if (host_.api()->channel_find(host_.ctx(), channel.c_str(), &id) != SKR_OK) {
      return fail("not_found", "no service channel " + channel + " now");
    }
    if (!skr::support::parseJson(value)) return fail("bad_request", "the request is not JSON");
    // The hub refused the call: the rules or limits of the account the bridge acts as.
    fail("refused", "this hub refuses the call of " + channel + " (see its log)");
  }

  void onPropsRequest(const Incoming& in) {
    if (in.reply.empty()) return;
    const auto name = subjectChannel(prefix_ + "._props", in.subject);
    auto it = name ? exported_.find(*name) : exported_.end();
    if (it == exported_.end()) {
      client_->publish(Lane::prompt, in.reply, jsonQuote("no exported channel there"), {}, {},
                       "not_found");
      return;
    }
    client_->publish(Lane::prompt, in.reply, propsJson(it->first, it->second));
  }

  static std::string propsJson(const std::string& name, const Exported& e) {
    Json::Value v(Json::objectValue);
    v["channel"] = name;
    v["kind"] = e.kind == SKR_CHANNEL_SERVICE ? "service" : "streaming";
    v["mime"] = e.mime;
    v["props"] = e.props;
    return skr::support::writeJson(v);
  }

  // --- services: local requests to imported NATS subjects ------------------------------------
  void callNats(size_t i, const plugin::ServiceRequest& r) {
    const Import& im = config_.imports[i];
    const uint64_t id = next_request_++;
    const int64_t timeout_ms = im.timeout_ms > 0 ? im.timeout_ms : config_.request_timeout_ms;
    Pending p{i, r.id, host_.nowNs() + timeout_ms * 1'000'000};
    if (!client_->publish(Lane::prompt, im.subject, r.value_json,
                          client_->inbox() + "." + std::to_string(id), r.command)) {
      respondImport(p, R"({"error":"overflow","message":"the bridge's queue to NATS is full"})");
      return;
    }
    pending_.emplace(id, p);
  }

  void onReply(const Incoming& in) {
    const size_t dot = in.subject.rfind('.');
    const uint64_t id = std::strtoull(in.subject.c_str() + dot + 1, nullptr, 10);
    auto it = pending_.find(id);
    if (it == pending_.end()) return;  // timed out already
    const Pending p = it->second;
    pending_.erase(it);
    if (in.no_responders) {
      respondImport(p, R"({"error":"no_responders","message":"nobody answers )" +
                           config_.imports[p.import].subject + "\"}");
    } else if (!in.error.empty()) {
      respondImport(p,
                    "{\"error\":" + jsonQuote(in.error) + ",\"message\":" + asJson(in.data) + "}");
    } else {
      // As it came when it is JSON (the hub parses it), else as a string.
      if (!respondImport(p, in.data.empty() ? "null" : in.data))
        respondImport(p, jsonQuote(in.data));
    }
  }

  bool respondImport(const Pending& p, const std::string& value_json) {
    auto it = imports_.find(kFirstRoute + p.import);
    return it != imports_.end() && it->second.service.respond(p.request, value_json);
  }

  void expireRequests() {
    const int64_t now = host_.nowNs();
    for (auto it = pending_.begin(); it != pending_.end();) {
      if (it->second.deadline_ns > now) {
        ++it;
        continue;
      }
      const Pending p = it->second;
      it = pending_.erase(it);
      ++timeouts_;
      respondImport(p, R"({"error":"timeout","message":"no answer from )" +
                           config_.imports[p.import].subject + " in time\"}");
    }
    // Properties changed since the last tick go out once.
    for (auto& [name, e] : exported_) {
      if (!e.props_dirty || !client_->connected()) continue;
      e.props_dirty = false;
      client_->publish(Lane::bulk, channelSubject(prefix_ + "._props", name), propsJson(name, e));
    }
  }

  void publishStatus() {
    const ClientStats s = client_->stats();
    Json::Value v(Json::objectValue);
    v["state"] = s.state;
    v["server"] = s.server;
    v["prefix"] = prefix_;
    v["connects"] = Json::UInt64(s.connects);
    v["disconnects"] = Json::UInt64(s.disconnects);
    v["out_msgs"] = Json::UInt64(s.out_msgs);
    v["out_bytes"] = Json::UInt64(s.out_bytes);
    v["out_dropped"] = Json::UInt64(s.out_dropped);
    v["out_queued_bytes"] = Json::UInt64(s.out_queued_bytes);
    v["in_msgs"] = Json::UInt64(s.in_msgs);
    v["in_bytes"] = Json::UInt64(s.in_bytes);
    v["in_dropped"] = Json::UInt64(s.in_dropped);
    v["exported"] = Json::UInt64(exported_.size());
    v["imported"] = Json::UInt64(imports_.size());
    v["pending_requests"] = Json::UInt64(pending_.size());
    v["request_timeouts"] = Json::UInt64(timeouts_);
    Json::Value kv(Json::objectValue);
    for (const auto& m : mirrors_) kv[m->db()] = m->status();
    v["kv"] = kv;
    v["last_error"] = s.last_error;
    const std::string json = skr::support::writeJson(v);
    status_.publish(json);
    if (client_->connected()) client_->publish(Lane::bulk, prefix_ + "._status", json);
  }

  plugin::Host& host_;
  BridgeConfig config_;
  std::string prefix_;
  std::string own_prefix_;
  std::unique_ptr<NatsClient> client_;
  plugin::StreamChannel status_;
  std::unique_ptr<plugin::Requester> requester_;
  plugin::ChannelWatch watch_;
  plugin::TickHandle ticks_;
  plugin::TickHandle status_tick_;
  std::map<uint64_t, Imported> imports_;      // by route
  std::map<std::string, Exported> exported_;  // by channel name
  std::map<uint64_t, std::string> routes_;    // exported services' routes -> channel name
  uint64_t next_route_ = kFirstRoute + 4096;
  std::map<uint64_t, Pending> pending_;
  uint64_t next_request_ = 1;
  uint64_t timeouts_ = 0;
  std::vector<std::unique_ptr<KvMirrorLink>> mirrors_;
};

namespace config = skr::config;
constexpr skr_config_key kConfig[] = {
    config::array("servers", R"(["nats://127.0.0.1:4222"])",
                  "NATS server URLs (several for a cluster; the client fails over)")
        .min(1),
    config::string("user", "", "user name (with password)"),
    config::string("password", "", "password of user"),
    config::string("token", "", "an authentication token"),
    config::string("creds_file", "", "a .creds file (user JWT and nkey seed)"),
    config::string("nkey", "", "an nkey user's public key, with nkey_seed_file"),
    config::string("nkey_seed_file", "", "the file holding that nkey's seed"),
    config::string("tls_ca", "", "CA certificates (PEM) to verify the server: turns TLS on"),
    config::string("tls_cert", "", "client certificate chain (PEM), with tls_key"),
    config::string("tls_key", "", "client private key (PEM)"),
    config::string("prefix", "",
                   "subject prefix of exported channels (default skrobot.<hub_name>)"),
    config::array("export", "[]", "channel-name patterns to publish on NATS (\"!\" excludes)"),
    config::array("import", "[]",
                  "{\"subject\", \"as\", \"mime\", \"service\", \"timeout_ms\"}: NATS subjects "
                  "as channels <module>.<as>"),
    config::array("kv", "[]", "{\"db\", \"bucket\"}: named databases mirrored to JetStream KV"),
    config::string("queue_group", "", "queue group for exported services' NATS subscriptions"),
    config::integer("request_timeout_ms", "2000", "calls of imported services").range(1, 3'600'000),
    config::integer("connect_timeout_ms", "2000", "one connect attempt").range(1, 600'000),
    config::integer("reconnect_min_ms", "100", "first retry delay (doubles each attempt)")
        .range(1, 3'600'000),
    config::integer("reconnect_max_ms", "5000", "longest retry delay").range(1, 3'600'000),
    config::integer("queue_bytes", "67108864", "each way's queue; beyond it messages are dropped")
        .range(65536, 4294967296.0),
};

}  // namespace

SKR_MODULE_WITH_CONFIG(NatsBridge, "nats-bridge", "1.0.0",
                       "a hub's channels, services and databases on a NATS cluster", 0, kConfig)
