// SPDX-License-Identifier: Apache-2.0
// ros2-bridge: ROS 2 topics as the hub's channels and channels as ROS 2 topics, on one DDS domain
// (docs/ros2.md, "The bridge"). An imported topic is a streaming channel of the module from start
// (its samples as CDR, or converted to JSON); an exported channel is written to its topic while a
// ROS 2 reader is matched (the hub subscription follows the readers). The DDS side runs on the
// bridge's own thread (DdsWorker); the loop only moves bytes between it and the channels.
#include "bridge_config.h"
#include "dds_worker.h"
#include "ros_names.h"

#include <skrobot/ros2/definitions.h>
#include <skrobot/ros2/images.h>
#include <skrobot/runtime/flow/name_pattern.h>
#include <skrobot/plugin.hpp>
#include <skrobot/plugin_channels.hpp>
#include <skrobot/plugin_watch.hpp>
#include <skrobot/support/config.hpp>
#include <skrobot/support/json.hpp>
#include <skrobot/support/media_props.hpp>
#include <skrobot/support/pin_library.hpp>

#include <cstdlib>
#include <iterator>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace {

// Fast DDS stays mapped when the hub unloads this module (--list-modules loads and unloads it
// without a participant): its singletons outlive any dlclose (pin_library.hpp).
[[maybe_unused]] const bool kFastDdsPinned = skr::support::pinLoadedLibrary("libfastrtps.so.2.9") &&
                                             skr::support::pinLoadedLibrary("libfastcdr.so.1");

using namespace skr::ros2_bridge;
namespace plugin = skr::plugin;
namespace ros2 = skr::ros2;
namespace media = skr::media;

struct Counters {
  std::uint64_t messages = 0, bytes = 0, malformed = 0, dropped = 0;
  std::int32_t matched = 0;
  std::string incompatible;  // the last QoS policy a remote endpoint disagreed on
  std::string last_error;
};

class Ros2Bridge final : public plugin::Module {
 public:
  explicit Ros2Bridge(plugin::Host& host) : host_(host) {
    auto config = skr::support::parseJsonObject(host.configJson());
    if (!config) throw plugin::Failure(SKR_ERR_CONFIG, config.error().message);
    const auto problems = readConfig(*config, std::getenv("ROS_DOMAIN_ID"), config_);
    for (const auto& p : problems) host.configError(p.key.c_str(), p.reason);
    if (!problems.empty()) {
      throw plugin::Failure(SKR_ERR_CONFIG, std::to_string(problems.size()) +
                                                " problem(s) in the config (logged above)");
    }
  }

  void start() override {
    loadDefinitions();
    // Each type, and every type it uses, must be known before anything is created.
    for (const auto* list : {&config_.imports, &config_.exports, &config_.export_patterns}) {
      for (const TopicItem& t : *list) {
        if (auto r = registry_.resolve(t.type); !r) {
          throw plugin::Failure(SKR_ERR_CONFIG, t.ros + ": " + r.error().message);
        }
      }
    }
    for (const auto* list : {&config_.service_imports, &config_.service_exports}) {
      for (const ServiceItem& t : *list) {
        for (const char* half : {"_Request", "_Response"}) {
          if (auto r = registry_.resolve(t.type + half); !r) {
            throw plugin::Failure(SKR_ERR_CONFIG, t.ros + ": " + r.error().message);
          }
        }
      }
    }
    if (config_.participant.allow_non_loopback) {
      std::string imports;
      for (const TopicItem& t : config_.imports) imports += (imports.empty() ? "" : ", ") + t.ros;
      host_.log.warn("ROS2-OPEN", "domain ", config_.participant.domain, " on ",
                     joined(config_.participant.interfaces),
                     ": DDS has no authentication; any participant there may publish into ",
                     imports.empty() ? "no import" : imports, " (docs/security.md)");
    }
    imports_.resize(config_.imports.size());
    for (const TopicItem& t : config_.exports) exports_.push_back(Export{t});
    for (std::size_t i = 0; i < config_.imports.size(); ++i) addImport(i);
    service_imports_.resize(config_.service_imports.size());
    service_exports_.resize(config_.service_exports.size());
    requester_ = std::make_unique<plugin::Requester>(host_);
    for (std::size_t i = 0; i < config_.service_imports.size(); ++i) addServiceImport(i);
    worker_ = std::make_unique<DdsWorker>(config_, registry_,
                                          [this] { host_.post([this] { drain(); }); });
    if (auto r = worker_->start(); !r) {
      worker_.reset();
      throw plugin::Failure(SKR_ERR_CONFIG, r.error().message);
    }
    for (std::size_t i = 0; i < imports_.size(); ++i) {
      if (imports_[i].subscribed) worker_->setReading(i, true);  // subscribed before the worker
    }
    status_ =
        plugin::StreamChannel(host_, "status", "application/json",
                              R"({"note": "the bridge's topics and counters, every second"})");
    if (!config_.export_patterns.empty()) {
      for (const TopicItem& t : config_.export_patterns) {
        patterns_.push_back(*skr::flow::NamePattern::parse(t.channel));  // checked by readConfig
      }
      watch_ =
          plugin::ChannelWatch(host_, [this](const plugin::ChannelEvent& ev) { onChannel(ev); });
    }
    status_tick_ = host_.onTick(plugin::Tick::one_sec, [this] { publishStatus(); });
    expire_tick_ = host_.onTick(plugin::Tick::slow, [this] { expireRequests(); });
    host_.log.info("ROS2-BRIDGE", "domain ", config_.participant.domain, " on ",
                   joined(config_.participant.interfaces), ", node ", config_.ns,
                   config_.ns == "/" ? "" : "/", config_.node, ", ", config_.imports.size(),
                   " import(s), ", config_.exports.size(), " export(s), ",
                   config_.export_patterns.size(), " export pattern(s), ",
                   config_.service_imports.size() + config_.service_exports.size(), " service(s), ",
                   registry_.size(), " types; participant ", worker_->participantGuid());
  }

  void stop() override {
    watch_.reset();
    if (worker_) worker_->stop();  // no wake after this
    worker_.reset();
    for (auto& [tag, p] : pending_) {
      service_imports_[p.item].channel.respond(
          p.request, R"({"error":"stopped","message":"the bridge stopped"})");
    }
    pending_.clear();
    for (auto& s : service_imports_) s.channel = {};
    requester_.reset();
    expire_tick_.reset();
    status_tick_.reset();
    status_ = {};
    for (auto& e : exports_) e.subscription.reset();
    for (auto& i : imports_) i.channel = {};
  }

 private:
  struct Import {
    plugin::StreamChannel channel;
    Counters counters;
    bool subscribed = false;  // the channel has subscribers
    // media: the last frame's encoding and size, as the channel's properties say them
    bool frames_seen = false;
    media::Format format = media::Format::jpeg;
    std::uint16_t width = 0, height = 0;
  };
  struct Export {
    explicit Export(TopicItem t) : item(std::move(t)) {}
    TopicItem item;
    plugin::Subscription subscription;
    Counters counters;
    bool removed = false;  // a pattern's channel that went away
  };
  struct ServiceImport {
    plugin::ServiceChannel channel;
    Counters counters;  // matched: ROS 2 servers
  };
  // A hub request waiting for a ROS 2 server's reply.
  struct Pending {
    std::size_t item = 0;
    std::uint64_t request = 0;  // the hub's request id
    std::int64_t sequence = 0;  // our request sample's, once written (0 before)
    std::int64_t deadline_ns = 0;
  };

  static bool latched(const TopicItem& t) {
    return t.qos.durability == Durability::transient_local;
  }

  static std::string joined(const std::vector<std::string>& list) {
    std::string out;
    for (const auto& s : list) out += (out.empty() ? "" : ", ") + s;
    return out;
  }

  void loadDefinitions() {
    const auto shipped = ros2::shippedFolder();
    if (shipped.empty()) {
      host_.log.warn("ROS2-DEFINITIONS",
                     "the shipped interfaces were not found beside the module "
                     "(share/skrobot/ros2/msgs): only the config's folders");
    } else if (auto r = registry_.addFolder(shipped); !r) {
      throw plugin::Failure(SKR_ERR_CONFIG, r.error().message);
    }
    for (const auto& folder : config_.definitions) {
      if (auto r = registry_.addFolder(folder); !r) {
        throw plugin::Failure(SKR_ERR_CONFIG, "definitions: " + r.error().message);
      }
    }
  }

  void addImport(std::size_t i) {
    const TopicItem& t = config_.imports[i];
    Json::Value props(Json::objectValue);
    props["ros_topic"] = t.ros;
    props["ros_type"] = t.type;
    // A transient_local topic's kept samples reach each subscriber that comes later (one per
    // ROS 2 writer: several /tf_static broadcasters each keep theirs).
    if (latched(t)) props["retained"] = true;
    std::string mime = "application/octet-stream";
    if (t.encoding == Encoding::cdr) {
      skr::support::addTypeProperties(props,
                                      {"cdr", t.type, "ros2msg", registry_.schemaText(t.type)});
    } else if (t.encoding == Encoding::json) {
      skr::support::addTypeProperties(props, {"json", "", "", ""});
      mime = "application/json";
    } else if (t.type == ros2::kCompressedImageType) {
      const auto& jpeg = *media::encodingInfo(media::Format::jpeg);
      skr::support::addMediaProperties(props, jpeg);
      mime = jpeg.mime;
    } else {
      // Which raw encoding an Image topic carries is known from its first sample (frameProperties).
      const auto& raw = *media::encodingInfo(media::Format::rgb8);
      props["message_encoding"] = std::string(media::kMessageEncoding);
      props["flow_type"] = std::string(raw.flow_type);
    }
    // The topic is read while the channel has subscribers (the DDS reader follows them).
    imports_[i].channel = plugin::StreamChannel(
        host_, t.channel, mime, skr::support::writeJson(props), [this, i](bool first) {
          imports_[i].subscribed = first;
          if (worker_) worker_->setReading(i, first);
        });
  }

  // A media import's channel says the encoding and size of its frames, from the first one and
  // whenever they change (subscribers hear the new properties).
  void frameProperties(Import& in, std::string_view frame) {
    const auto f = media::parseFrame(frame);
    if (!f) return;
    const auto& h = f->header;
    if (in.frames_seen && h.format == in.format && h.width == in.width && h.height == in.height) {
      return;
    }
    in.frames_seen = true;
    in.format = h.format;
    in.width = h.width;
    in.height = h.height;
    Json::Value props(Json::objectValue);
    skr::support::addMediaProperties(props, *media::encodingInfo(h.format));
    props["width"] = h.width;
    props["height"] = h.height;
    for (const auto& key : props.getMemberNames()) {
      (void)plugin::dbSet(host_, in.channel.name(), key, skr::support::writeJson(props[key]));
    }
  }

  void addServiceImport(std::size_t i) {
    const ServiceItem& t = config_.service_imports[i];
    Json::Value props(Json::objectValue);
    props["ros_service"] = t.ros;
    props["ros_type"] = t.type;
    props["note"] = "calls the ROS 2 service " + t.ros +
                    ": any command, the request's fields "
                    "as the value; the answer is the response's fields, or {\"error\": ...}";
    service_imports_[i].channel = plugin::ServiceChannel(
        host_, t.channel, [this, i](const plugin::ServiceRequest& r) { callRos(i, r); },
        skr::support::writeJson(props));
  }

  void callRos(std::size_t i, const plugin::ServiceRequest& r) {
    ServiceImport& s = service_imports_[i];
    if (s.counters.matched == 0 || !worker_) {
      s.channel.respond(r.id, R"({"error":"no_server","message":"no ROS 2 server of )" +
                                  config_.service_imports[i].ros + R"( is matched"})");
      return;
    }
    const std::uint64_t tag = next_tag_++;
    pending_[tag] = {i, r.id, 0, host_.nowNs() + config_.service_imports[i].timeout_ms * 1000000};
    s.counters.messages += 1;
    worker_->request(i, tag, r.value_json);
  }

  void answer(std::map<std::uint64_t, Pending>::iterator it, const std::string& value_json) {
    service_imports_[it->second.item].channel.respond(it->second.request, value_json);
    pending_.erase(it);
  }

  void expireRequests() {
    const std::int64_t now = host_.nowNs();
    for (auto it = pending_.begin(); it != pending_.end();) {
      auto next = std::next(it);
      if (it->second.deadline_ns <= now) {
        service_imports_[it->second.item].counters.dropped += 1;
        answer(it, R"({"error":"timeout","message":"no reply from the ROS 2 server in time"})");
      }
      it = next;
    }
  }

  void serviceEvent(BridgeEvent& ev) {
    if (ev.list == ItemList::service_exports) {
      Counters& c = service_exports_[ev.item].counters;
      const ServiceItem& t = config_.service_exports[ev.item];
      switch (ev.kind) {
        case BridgeEvent::Kind::matched:
          c.matched = ev.matched;
          break;
        case BridgeEvent::Kind::request: {
          c.messages += 1;
          const std::size_t item = ev.item;
          const SampleIdentity to = ev.identity;
          const bool sent = requester_->request(t.channel, t.command, ev.payload,
                                                [this, item, to](bool ok, const std::string& v) {
                                                  if (worker_) worker_->reply(item, to, ok, v);
                                                });
          if (!sent && worker_) worker_->reply(item, to, false, "no service channel " + t.channel);
          break;
        }
        case BridgeEvent::Kind::malformed:
          c.malformed += 1;
          c.last_error = ev.text;
          host_.log.warn("ROS2-SERVICE-FAILED", t.ros, ": ", ev.text);
          break;
        default:
          c.dropped += ev.kind == BridgeEvent::Kind::dropped ? 1 : 0;
          break;
      }
      return;
    }
    Counters& c = service_imports_[ev.item].counters;
    switch (ev.kind) {
      case BridgeEvent::Kind::matched:
        c.matched = ev.matched;
        break;
      case BridgeEvent::Kind::sent:
        if (auto it = pending_.find(ev.tag); it != pending_.end()) {
          it->second.sequence = ev.identity.sequence;
        }
        break;
      case BridgeEvent::Kind::reply:
        for (auto it = pending_.begin(); it != pending_.end(); ++it) {
          if (it->second.item == ev.item && it->second.sequence == ev.identity.sequence) {
            answer(it, ev.payload);
            break;
          }
        }
        break;
      case BridgeEvent::Kind::failed:
        c.malformed += 1;
        c.last_error = ev.text;
        if (auto it = pending_.find(ev.tag); it != pending_.end()) {
          Json::Value error(Json::objectValue);
          error["error"] = "invalid_argument";
          error["message"] = ev.text;
          answer(it, skr::support::writeJson(error));
        }
        break;
      default:
        c.dropped += ev.kind == BridgeEvent::Kind::dropped ? 1 : 0;
        break;
    }
  }

  // A channel added or removed: exported while it exists, by each pattern that matches it (not
  // the bridge's own channels: imports are never sent back).
  void onChannel(const plugin::ChannelEvent& ev) {
    if (ev.kind != SKR_CHANNEL_STREAMING || !worker_) return;
    if (ev.name.starts_with(std::string(host_.name()) + ".")) return;
    for (std::size_t p = 0; p < patterns_.size(); ++p) {
      if (!patterns_[p].matches(ev.name)) continue;
      const auto key = std::make_pair(p, ev.name);
      if (!ev.added) {
        if (auto it = matched_.find(key); it != matched_.end()) {
          worker_->removeExport(it->second);
          exports_[it->second].removed = true;
          exports_[it->second].subscription.reset();
          host_.log.info("ROS2-EXPORT", ev.name, " no longer exported to ",
                         exports_[it->second].item.ros, " (the channel went)");
          matched_.erase(it);
        }
        continue;
      }
      if (matched_.contains(key)) continue;
      const TopicItem& pattern = config_.export_patterns[p];
      auto ros = rosNameForChannel(pattern.ros, ev.name, config_.ns, config_.node);
      if (!ros) {
        host_.log.warn("ROS2-EXPORT", ev.name, " matches ", pattern.channel,
                       " but has no ROS name: ", ros.error().message);
        continue;
      }
      TopicItem t = pattern;
      t.ros = *ros;
      t.channel = ev.name;
      if (t.frame_id.empty()) t.frame_id = ev.name;
      const std::size_t i = worker_->addExport(t);
      if (exports_.size() != i) {  // the worker numbers them as exports_ grows
        host_.log.error("ROS2-EXPORT", "export numbering out of step at ", ev.name);
        continue;
      }
      exports_.push_back(Export{t});
      matched_[key] = i;
      host_.log.info("ROS2-EXPORT", ev.name, " exported to ", t.ros, " as ", t.type, " (",
                     pattern.channel, ")");
    }
  }

  // The exported channel is subscribed to while a ROS 2 reader is matched.
  void follow(std::size_t i) {
    Export& e = exports_[i];
    const bool wanted = e.counters.matched > 0 && !e.removed;
    if (wanted == e.subscription.active()) return;
    if (!wanted) {
      e.subscription.reset();
      return;
    }
    try {
      e.subscription =
          plugin::Subscription(host_, e.item.channel, [this, i](std::string_view payload) {
            if (!worker_ || !worker_->write(i, payload)) return;
            exports_[i].counters.messages += 1;
            exports_[i].counters.bytes += payload.size();
          });
    } catch (const plugin::Failure& f) {
      exports_[i].counters.last_error = f.what();
      host_.log.warn("ROS2-EXPORT", exports_[i].item.channel, ": ", f.what());
    }
  }

  void drain() {
    if (!worker_) return;
    for (BridgeEvent& ev : worker_->take()) {
      if (ev.list == ItemList::service_imports || ev.list == ItemList::service_exports) {
        serviceEvent(ev);
        continue;
      }
      const bool import = ev.list == ItemList::imports;
      if (!import && ev.item >= exports_.size()) continue;
      const TopicItem& t = import ? config_.imports[ev.item] : exports_[ev.item].item;
      Counters& c = import ? imports_[ev.item].counters : exports_[ev.item].counters;
      switch (ev.kind) {
        case BridgeEvent::Kind::sample:
          c.messages += 1;
          c.bytes += ev.payload.size();
          if (t.encoding == Encoding::media) frameProperties(imports_[ev.item], ev.payload);
          if (!latched(t) || ev.text.empty()) {
            imports_[ev.item].channel.publish(ev.payload);
          } else if (!imports_[ev.item].channel.publishRetained(ev.text, ev.payload)) {
            // Over the hub's bounds (64 writers, 16 MiB): sent to those here now, not kept.
            c.dropped += 1;
            imports_[ev.item].channel.publish(ev.payload);
          }
          break;
        case BridgeEvent::Kind::matched:
          c.matched = ev.matched;
          if (!import) follow(ev.item);
          if (import && latched(t) && !ev.text.empty()) {
            (void)imports_[ev.item].channel.clearRetained(ev.text);
          }
          break;
        case BridgeEvent::Kind::incompatible_qos:
          if (c.incompatible != ev.text) {
            host_.log.warn("ROS2-QOS-INCOMPATIBLE", t.ros, ": a remote ",
                           import ? "writer" : "reader", " disagrees with our ",
                           import ? "reader" : "writer", " on ", ev.text,
                           " (ours: ", describe(t.qos), "); set \"qos\" on ",
                           import ? "import " : "export ", t.ros);
          }
          c.incompatible = ev.text;
          break;
        case BridgeEvent::Kind::malformed:
          if (c.malformed++ == 0 || c.last_error != ev.text) {
            host_.log.warn("ROS2-MALFORMED", t.ros, ": ", ev.text, " (dropped; counted in ",
                           host_.name(), ".status)");
          }
          c.last_error = ev.text;
          break;
        case BridgeEvent::Kind::dropped:
          c.dropped += 1;
          break;
        default:
          break;
      }
    }
  }

  void publishStatus() {
    if (!status_.hasSubscribers() || !worker_) return;
    Json::Value s(Json::objectValue);
    s["domain"] = config_.participant.domain;
    s["participant"] = worker_->participantGuid();
    s["node"] = config_.ns == "/" ? "/" + config_.node : config_.ns + "/" + config_.node;
    s["topics"] = Json::Value(Json::arrayValue);
    auto add = [&](const TopicItem& t, const Counters& c, bool import) {
      Json::Value v(Json::objectValue);
      v["ros"] = t.ros;
      v["type"] = t.type;
      v["direction"] = import ? "import" : "export";
      v["channel"] = import ? std::string(host_.name()) + "." + t.channel : t.channel;
      v["encoding"] = std::string(encodingName(t.encoding));
      v["qos"] = describe(t.qos);
      v["matched"] = c.matched;
      v["messages"] = Json::UInt64(c.messages);
      v["bytes"] = Json::UInt64(c.bytes);
      v["malformed"] = Json::UInt64(c.malformed);
      v["dropped"] = Json::UInt64(c.dropped);
      if (!c.incompatible.empty()) v["incompatible_qos"] = c.incompatible;
      if (!c.last_error.empty()) v["last_error"] = c.last_error;
      s["topics"].append(std::move(v));
    };
    for (std::size_t i = 0; i < imports_.size(); ++i)
      add(config_.imports[i], imports_[i].counters, true);
    for (const Export& e : exports_) {
      if (!e.removed) add(e.item, e.counters, false);
    }
    s["services"] = Json::Value(Json::arrayValue);
    auto addService = [&](const ServiceItem& t, const Counters& c, bool import) {
      Json::Value v(Json::objectValue);
      v["ros"] = t.ros;
      v["type"] = t.type;
      v["direction"] = import ? "import" : "export";
      v["channel"] = import ? std::string(host_.name()) + "." + t.channel : t.channel;
      v["matched"] = c.matched;
      v["requests"] = Json::UInt64(c.messages);
      v["failed"] = Json::UInt64(c.malformed);
      v["timeouts"] = Json::UInt64(c.dropped);
      if (!c.last_error.empty()) v["last_error"] = c.last_error;
      s["services"].append(std::move(v));
    };
    for (std::size_t i = 0; i < service_imports_.size(); ++i) {
      addService(config_.service_imports[i], service_imports_[i].counters, true);
    }
    for (std::size_t i = 0; i < service_exports_.size(); ++i) {
      addService(config_.service_exports[i], service_exports_[i].counters, false);
    }
    status_.publish(skr::support::writeJson(s));
  }

  plugin::Host& host_;
  BridgeConfig config_;
  ros2::Registry registry_;
  std::unique_ptr<DdsWorker> worker_;
  std::vector<Import> imports_;
  std::vector<Export> exports_;  // the config's, then those patterns matched (by worker item)
  std::vector<skr::flow::NamePattern> patterns_;  // of config_.export_patterns
  std::map<std::pair<std::size_t, std::string>, std::size_t>
      matched_;  // (pattern, channel) -> item
  plugin::ChannelWatch watch_;
  std::vector<ServiceImport> service_imports_;
  struct ServiceExport {
    Counters counters;
  };
  std::vector<ServiceExport> service_exports_;
  std::unique_ptr<plugin::Requester> requester_;
  std::map<std::uint64_t, Pending> pending_;  // by our tag
  std::uint64_t next_tag_ = 1;
  plugin::StreamChannel status_;
  plugin::TickHandle status_tick_;
  plugin::TickHandle expire_tick_;
};

namespace cfg = skr::config;
constexpr skr_config_key kConfig[] = {
    cfg::integer("domain", "-1", "the DDS domain (-1: ROS_DOMAIN_ID, else 0)").range(-1, 232),
    cfg::string("distribution", "jazzy", "the ROS 2 distribution of the other nodes (graph layout)")
        .oneOf("humble|iron|jazzy"),
    cfg::string("node", "skrobot", "the node name ROS 2's tools show"),
    cfg::string("namespace", "/", "the node's namespace; relative topic names resolve in it"),
    cfg::array("interfaces", "[\"127.0.0.1\"]",
               "addresses of the network interfaces DDS may use (loopback unless listed)"),
    cfg::array("peers", "[\"127.0.0.1\"]", "where other participants are looked for (unicast)"),
    cfg::integer("max_participants", "20", "participants per peer address looked for")
        .range(1, 120),
    cfg::integer("socket_buffer_bytes", "0", "UDP socket buffers asked for (0: the system's)")
        .range(0, 1073741824),
    cfg::array("definitions", "[]", "folders of ROS 2 interface packages beside the shipped ones"),
    cfg::array("import", "[]", "ROS 2 topics as channels: {ros, type, channel, encoding, qos}"),
    cfg::array("export", "[]",
               "channels (or a name pattern, ros a template with {owner} and {name}) as ROS 2 "
               "topics: {channel, ros, type, encoding, qos, frame_id}"),
    cfg::array("services_import", "[]", "ROS 2 services as service channels: {ros, type, channel}"),
    cfg::array("services_export", "[]",
               "service channels as ROS 2 services: {channel, command, ros, type, timeout_ms}"),
    cfg::integer("queue_bytes", "67108864", "samples waiting for the DDS thread or the loop")
        .range(65536, 4294967296.0),
};

}  // namespace

SKR_MODULE_WITH_CONFIG(Ros2Bridge, "ros2-bridge", "0.1.0",
                       "ROS 2 topics as channels and channels as ROS 2 topics (Fast DDS)", 0,
                       kConfig)
