// SPDX-License-Identifier: Apache-2.0
// nao-bridge: a Nao on the FlowNetwork. See docs/nao.md.
//   <name>.command   service: JSON commands (commands.h), answered {"ok":true} or an error
//   <name>.status    streaming: {"connected":..,"backend":..,"error":..,"retry_in_ms":..,
//                    "missing":{service: why}}
//   <name>.joints|sonar|battery|posture|fall   streaming state at configured rates
//   <name>.results   streaming: outcome of each command read from a configured queue
// Channel calls happen on the hub's loop thread; robot I/O on the RobotWorker thread, whose
// results come back through host.post().
#include "backends.h"
#include "robot_worker.h"

#include <skrobot/plugin_channels.hpp>
#include <skrobot/support/config.hpp>

#include <skrobot/support/json.hpp>
#include <skrobot/support/media_props.hpp>

#include <json/value.h>

#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace {

namespace nao = skr::nao;
namespace plugin = skr::plugin;
using nao::StateKind;

using skr::support::writeJson;

class NaoBridge final : public plugin::Module {
 public:
  explicit NaoBridge(plugin::Host& host) : host_(host) {
    auto parsed = skr::support::parseJsonObject(host.configJson());
    if (!parsed) {  // the host hands over the module's config object; this would be a host bug
      throw plugin::Failure(SKR_ERR_CONFIG, "config: " + parsed.error().message);
    }
    const Json::Value config = std::move(parsed.value());
    // The host checked the keys against kConfig and filled in the defaults; what a declaration
    // cannot say (the members of rates_hz and queues, min <= max) is checked here.
    backend_name_ = host.configString("backend");
    const Json::Value& rates = config["rates_hz"];
    for (StateKind k : nao::kStateKinds) {
      const char* n = nao::stateName(k);
      if (rates.isObject() && rates.isMember(n)) {
        if (!rates[n].isNumeric() || rates[n].asDouble() < 0 || rates[n].asDouble() > 100) {
          host.configError("rates_hz", std::string(n) + " must be a number in [0, 100]");
          throw plugin::Failure(SKR_ERR_CONFIG, "invalid config");
        }
        worker_opt_.rate_hz[static_cast<std::size_t>(k)] = rates[n].asDouble();
      }
    }
    const Json::Value& queues = config["queues"];
    if (!queues.isNull() && !queues.isArray()) {
      host.configError("queues", "must be an array of channel names (\"user.name\")");
      throw plugin::Failure(SKR_ERR_CONFIG, "invalid config");
    }
    for (const auto& q : queues) {
      if (!q.isString() || q.asString().find('.') == std::string::npos) {
        host.configError("queues", "each entry must be a channel name \"user.name\"");
        throw plugin::Failure(SKR_ERR_CONFIG, "invalid config");
      }
      queues_.push_back(q.asString());
    }
    worker_opt_.reconnect_min_ms = static_cast<int>(host.configInt("reconnect_min_ms"));
    worker_opt_.reconnect_max_ms = static_cast<int>(host.configInt("reconnect_max_ms"));
    if (worker_opt_.reconnect_max_ms < worker_opt_.reconnect_min_ms) {
      host.configError("reconnect_min_ms", "must be <= reconnect_max_ms");
      throw plugin::Failure(SKR_ERR_CONFIG, "invalid config");
    }
  }

  void start() override {
    const std::string self(host_.name());
    const auto names = nao::jointNames();
    Json::Value joint_props(Json::objectValue);
    joint_props["units"] = "rad";
    for (const auto& n : names) joint_props["names"].append(n);
    joint_props["hand_units"] = "fraction open (LHand, RHand)";
    // The joints' type (docs/channels.md, "Typed channels"): one angle per name, in their order.
    const std::string joints_schema =
        R"({"$schema":"http://json-schema.org/draft-07/schema#","title":"skrobot.nao.Joints",)"
        R"("description":"The Nao's joint angles in radians (hands: fraction open), in the )"
        R"(order of the channel's names property, docs/nao.md","type":"object",)"
        R"("required":["angles"],"properties":{"angles":{"type":"array","minItems":)" +
        std::to_string(names.size()) + R"(,"maxItems":)" + std::to_string(names.size()) +
        R"(,"items":{"type":"number"}}}})";
    skr::support::addTypeProperties(joint_props,
                                    {"json", "skrobot.nao.Joints", "jsonschema", joints_schema});
    const std::array<Json::Value, 5> props = {joint_props, props2("m", "left", "right"),
                                              props1("fraction", "charge"),
                                              props1("name", "posture"), props1("bool", "fallen")};
    for (StateKind k : nao::kStateKinds) {
      const auto i = static_cast<std::size_t>(k);
      Json::Value p = props[i];
      p["rate_hz"] = worker_opt_.rate_hz[i];
      p["backend"] = backend_name_;
      state_[i] = plugin::StreamChannel(host_, nao::stateName(k), "application/json", writeJson(p),
                                        [this, k](bool first) {
                                          if (worker_) worker_->setStreaming(k, first);
                                        });
    }
    status_ = plugin::StreamChannel(
        host_, "status", "application/json",
        R"({"keys":["connected","backend","error","retry_in_ms","missing"]})", [this](bool first) {
          if (first) status_.publish(status_json_);
        });
    results_ = plugin::StreamChannel(host_, "results", "application/json",
                                     R"({"keys":["queue","seq","ok","code","error"]})");
    command_ = plugin::ServiceChannel(
        host_, "command", [this](const plugin::ServiceRequest& r) { onRequest(r); },
        R"({"commands":["say","posture","head","joints","walk","stop","leds","rest","wake"]})");
    auto backend = makeBackend();
    // The simulator is there at once; a real robot is "connecting" until the worker says so.
    // (The worker thread does not run yet: asking the backend here is safe.)
    const bool ready = backend->connected();
    setStatus(nao::WorkerStatus{ready, ready ? backend->describe() : "connecting", 0, {}});

    worker_ = std::make_unique<nao::RobotWorker>(
        std::move(backend), worker_opt_,
        nao::WorkerCallbacks{
            [this](const nao::WorkerStatus& s) { host_.post([this, s] { setStatus(s); }); },
            [this](StateKind k, const std::string& j) {
              host_.post([this, k, j] { state_[static_cast<std::size_t>(k)].publish(j); });
            }});
    for (StateKind k : nao::kStateKinds) {
      worker_->setStreaming(k, state_[static_cast<std::size_t>(k)].hasSubscribers());
    }
    worker_->start();
    for (const auto& q : queues_) {
      subs_.emplace_back(
          host_, q, [this, q](std::string_view payload) { onQueued(q, std::string(payload)); });
    }
    host_.log.info("NAO-START", "backend ", backend_name_, ", ", queues_.size(), " queue(s)");
  }

  void stop() override {
    subs_.clear();
    if (worker_) worker_->stop();  // joins: nothing posts after this
    worker_.reset();
    command_.reset();
    results_.reset();
    status_.reset();
    for (auto& s : state_) s.reset();
  }

 private:
  static Json::Value props1(const char* units, const char* key) {
    Json::Value p(Json::objectValue);
    p["units"] = units;
    p["keys"].append(key);
    return p;
  }
  static Json::Value props2(const char* units, const char* a, const char* b) {
    Json::Value p = props1(units, a);
    p["keys"].append(b);
    return p;
  }

  std::unique_ptr<nao::RobotBackend> makeBackend() {
    if (backend_name_ == "simulated") {
      nao::SimOptions o;
      o.room_size_m = host_.configDouble("sim_room_m");
      o.battery = host_.configDouble("sim_battery");
      o.drain_scale = host_.configDouble("sim_drain_scale");
      return std::make_unique<nao::SimBackend>(o);
    }
    nao::NaoqiOptions o;
    o.client.host = host_.configString("host");
    o.client.port = static_cast<std::uint16_t>(host_.configInt("port"));
    o.client.connect_timeout_ms = static_cast<int>(host_.configInt("connect_timeout_ms"));
    o.client.lookup_timeout_ms = static_cast<int>(host_.configInt("call_timeout_ms"));
    o.client.max_payload = static_cast<std::uint32_t>(host_.configInt("max_message_bytes"));
    o.client.authenticate = host_.configBool("authenticate");
    if (!o.client.authenticate) {
      host_.log.warn("NAO-CONFIG",
                     "\"authenticate\": false: NAOqi 2.5 and later refuse every call until the "
                     "capability map is sent, even without a password; use it only with older "
                     "robots");
    }
    o.client.user = host_.configString("user");
    o.client.token = host_.configString("token");
    o.call_timeout_ms = o.client.lookup_timeout_ms;
    o.motion_timeout_ms = static_cast<int>(host_.configInt("motion_timeout_ms"));
    return std::make_unique<nao::NaoqiBackend>(o);
  }

  void setStatus(const nao::WorkerStatus& s) {
    if (s.connected != connected_ || s.detail != last_detail_) {
      if (s.connected) {
        host_.log.info("NAO-CONNECTED", s.detail);
      } else if (s.detail != "connecting") {
        host_.log.warn("NAO-DISCONNECTED", s.detail, "; retrying in ", s.retry_in_ms, " ms");
      }
    }
    // What the connected robot lacks: each service logged when it goes missing and when it is
    // found again.
    for (const auto& [service, why] : s.missing) {
      if (missing_.count(service) == 0) {
        host_.log.warn("NAO-SERVICE-MISSING", service, ": ", why,
                       "; its commands answer service_unavailable; looking again in ",
                       s.retry_in_ms, " ms");
      }
    }
    for (const auto& [service, why] : missing_) {
      if (s.connected && s.missing.count(service) == 0) {
        host_.log.info("NAO-SERVICE-FOUND", service);
      }
    }
    connected_ = s.connected;
    last_detail_ = s.detail;
    missing_ = s.missing;
    Json::Value v(Json::objectValue);
    v["connected"] = s.connected;
    v["backend"] = backend_name_;
    v["error"] = s.connected ? "" : s.detail;
    v["retry_in_ms"] = s.retry_in_ms;
    v["missing"] = Json::Value(Json::objectValue);
    for (const auto& [service, why] : s.missing) v["missing"][service] = why;
    status_json_ = writeJson(v);
    status_.publish(status_json_);
    plugin::dbSet(host_, std::string(host_.name()), "status", status_json_);
  }

  // Parses and checks on the loop thread, so refusals never wait for the robot. Queued commands
  // (`ordered`) report refusals through the worker too, so that their results keep queue order.
  template <class Reply>
  void run(const std::string& json, const std::string& default_cmd, bool ordered, Reply reply) {
    nao::Parsed p = nao::parseCommand(json, default_cmd);
    nao::CommandResult refusal = p.result;
    if (refusal.ok() && !connected_) {
      refusal = nao::CommandResult::failure(nao::CommandError::not_connected,
                                            "the robot is not connected (" + last_detail_ + ")");
    }
    auto back = [this, reply](nao::CommandResult r) { host_.post([reply, r] { reply(r); }); };
    if (refusal.ok()) {
      worker_->submit(std::move(p.command), back);
    } else if (ordered) {
      worker_->submitResult(refusal, back);
    } else {
      reply(refusal);
    }
  }

  void onRequest(const plugin::ServiceRequest& r) {
    const std::uint64_t id = r.id;
    run(r.value_json, r.command, false,
        [this, id](const nao::CommandResult& res) { command_.respond(id, res.json()); });
  }

  void onQueued(const std::string& queue, std::string payload) {
    const std::uint64_t seq = ++queue_seq_;
    run(payload, "", true, [this, queue, seq](const nao::CommandResult& res) {
      if (!res.ok()) host_.log.warn("NAO-QUEUE", queue, " #", seq, ": ", res.message);
      Json::Value v = res.toJson();
      v["queue"] = queue;
      v["seq"] = static_cast<Json::UInt64>(seq);
      results_.publish(writeJson(v));
    });
  }

  plugin::Host& host_;
  std::string backend_name_;
  nao::WorkerOptions worker_opt_;
  std::vector<std::string> queues_;
  std::array<plugin::StreamChannel, 5> state_;
  plugin::StreamChannel status_;
  plugin::StreamChannel results_;
  plugin::ServiceChannel command_;
  std::vector<plugin::Subscription> subs_;
  std::unique_ptr<nao::RobotWorker> worker_;
  bool connected_ = false;
  std::string last_detail_;
  std::map<std::string, std::string> missing_;  // as last reported by the worker
  std::string status_json_ = "{}";
  std::uint64_t queue_seq_ = 0;
};

namespace config = skr::config;
// The config keys (docs/nao.md): checked by the host before init, defaults filled in.
constexpr skr_config_key kConfig[] = {
    config::string("backend", "simulated",
                   "\"naoqi\": a real robot; \"simulated\": a kinematic Nao")
        .oneOf("simulated|naoqi"),
    config::string("host", "nao.local", "the robot's NAOqi host (naoqi)").nonEmpty(),
    config::integer("port", "9559", "the robot's NAOqi port (naoqi)").range(1, 65535),
    config::array("queues", "[]", "streaming channels (\"user.name\") whose messages are commands"),
    config::object(
        "rates_hz", "{}",
        "how often each state is read while subscribed: joints, sonar, battery, posture, "
        "fall (0..100 Hz; defaults 10, 5, 1, 2, 5)"),
    config::integer("reconnect_min_ms", "500",
                    "first retry delay after a failed or lost connection")
        .range(10, 3'600'000),
    config::integer("reconnect_max_ms", "10000", "longest retry delay (the delay doubles)")
        .range(10, 3'600'000),
    config::integer("connect_timeout_ms", "2000", "TCP connect timeout").range(1, 600'000),
    config::integer("call_timeout_ms", "2000",
                    "look-ups and state reads; a state read that times out drops the connection")
        .range(1, 600'000),
    config::integer("motion_timeout_ms", "30000", "commands (NAOqi answers when a motion is done)")
        .range(1, 3'600'000),
    config::integer("max_message_bytes", "16777216", "larger qi messages close the connection")
        .range(4096, 1 << 30),
    config::boolean("authenticate", "true",
                    "send the capability map first; NAOqi 2.5 and later refuse every call without "
                    "it (off only for older robots)"),
    config::string("user", "", "login for robots with a password (NAOqi 2.9)"),
    config::string("token", "", "password for robots with a password (NAOqi 2.9)"),
    config::number("sim_room_m", "4", "simulator: side of the square room, in metres")
        .range(1, 100),
    config::number("sim_battery", "1", "simulator: initial charge, fraction").range(0, 1),
    config::number("sim_drain_scale", "1", "simulator: battery drain speed-up").range(0, 1e6),
};

}  // namespace

SKR_MODULE_WITH_CONFIG(NaoBridge, "nao-bridge", "1.0.0",
                       "a Nao robot (NAOqi 2.x over qi, or simulated) on the FlowNetwork", 0,
                       kConfig)
