// SPDX-License-Identifier: Apache-2.0
#include "bridge_config.h"

#include "ros_names.h"

#include <skrobot/ros2/definitions.h>
#include <skrobot/ros2/images.h>
#include <skrobot/runtime/flow/name_pattern.h>

#include <charconv>
#include <set>

namespace skr::ros2_bridge {
namespace {

// Reads one object of the config, collecting problems under `path`.
class Reader {
 public:
  Reader(std::vector<ConfigProblem>& problems, const Json::Value& obj, std::string path,
         const std::set<std::string>& known)
      : problems_(problems), obj_(obj), path_(std::move(path)) {
    if (!obj.isObject()) {
      problem("", "must be an object");
      return;
    }
    for (const auto& member : obj.getMemberNames()) {
      if (!known.contains(member)) problem(member, "unknown key");
    }
  }

  void problem(const std::string& key, std::string reason) {
    std::string at = path_;
    if (!key.empty()) at += (at.empty() ? "" : ".") + key;
    problems_.push_back({std::move(at), std::move(reason)});
  }
  [[nodiscard]] const Json::Value& get(const char* key) const {
    static const Json::Value null;
    return obj_.isObject() ? obj_[key] : null;
  }
  std::string string(const char* key, const std::string& def, bool required = false) {
    const Json::Value& v = get(key);
    if (v.isNull()) {
      if (required) problem(key, "is required");
      return def;
    }
    if (!v.isString()) {
      problem(key, "must be a string");
      return def;
    }
    return v.asString();
  }
  std::int64_t integer(const char* key, std::int64_t def, std::int64_t lo, std::int64_t hi) {
    const Json::Value& v = get(key);
    if (v.isNull()) return def;
    if (!v.isIntegral()) {
      problem(key, "must be an integer");
      return def;
    }
    if (v.asInt64() < lo || v.asInt64() > hi) {
      problem(key, "must be " + std::to_string(lo) + " to " + std::to_string(hi));
      return def;
    }
    return v.asInt64();
  }
  std::vector<std::string> strings(const char* key, std::vector<std::string> def) {
    const Json::Value& v = get(key);
    if (v.isNull()) return def;
    if (!v.isArray()) {
      problem(key, "must be an array of strings");
      return def;
    }
    std::vector<std::string> out;
    for (Json::ArrayIndex i = 0; i < v.size(); ++i) {
      if (v[i].isString() && !v[i].asString().empty()) {
        out.push_back(v[i].asString());
      } else {
        problem(std::string(key) + "[" + std::to_string(i) + "]", "must be a non-empty string");
      }
    }
    return out;
  }
  [[nodiscard]] const std::string& path() const noexcept { return path_; }

 private:
  std::vector<ConfigProblem>& problems_;
  const Json::Value& obj_;
  std::string path_;
};

bool loopback(const std::string& address) {
  return address.starts_with("127.");
}

Qos readQos(std::vector<ConfigProblem>& problems, const Json::Value& v, const std::string& path,
            const Qos& def) {
  if (v.isNull()) return def;
  Reader r(problems, v, path,
           {"profile", "reliability", "durability", "history", "depth", "deadline_ms"});
  Qos qos = def;
  if (const std::string profile = r.string("profile", ""); !profile.empty()) {
    if (auto p = qosProfile(profile)) {
      qos = *p;
    } else {
      r.problem("profile", "must be default, sensor_data, services or system");
    }
  }
  if (const std::string s = r.string("reliability", ""); !s.empty()) {
    if (s == "reliable" || s == "best_effort") {
      qos.reliability = s == "reliable" ? Reliability::reliable : Reliability::best_effort;
    } else {
      r.problem("reliability", "must be reliable or best_effort");
    }
  }
  if (const std::string s = r.string("durability", ""); !s.empty()) {
    if (s == "volatile" || s == "transient_local") {
      qos.durability = s == "volatile" ? Durability::volatile_ : Durability::transient_local;
    } else {
      r.problem("durability", "must be volatile or transient_local");
    }
  }
  if (const std::string s = r.string("history", ""); !s.empty()) {
    if (s == "keep_last" || s == "keep_all") {
      qos.history = s == "keep_last" ? History::keep_last : History::keep_all;
    } else {
      r.problem("history", "must be keep_last or keep_all");
    }
  }
  qos.depth = static_cast<std::int32_t>(r.integer("depth", qos.depth, 1, 10000));
  qos.deadline_ms = r.integer("deadline_ms", qos.deadline_ms, 0, 86400000);
  return qos;
}

}  // namespace

std::string_view encodingName(Encoding e) {
  switch (e) {
    case Encoding::cdr:
      return "cdr";
    case Encoding::json:
      return "json";
    case Encoding::media:
      return "media";
  }
  return "cdr";
}

std::string channelForRosName(std::string_view ros) {
  std::string out;
  for (char c : ros) out.push_back(c == '/' ? '.' : c);
  while (!out.empty() && out.front() == '.') out.erase(out.begin());
  return out;
}

std::vector<ConfigProblem> readConfig(const Json::Value& config, const char* domain_env,
                                      BridgeConfig& out) {
  std::vector<ConfigProblem> problems;
  Reader r(problems, config, "",
           {"domain", "distribution", "node", "namespace", "interfaces", "peers",
            "max_participants", "socket_buffer_bytes", "definitions", "import", "export",
            "services_import", "services_export", "queue_bytes"});
  ParticipantConfig& p = out.participant;
  std::int64_t domain = r.integer("domain", -1, -1, 232);
  if (domain < 0) {
    domain = 0;
    if (domain_env != nullptr && *domain_env != '\0') {
      const std::string_view text(domain_env);
      int v = -1;
      const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
      if (ec != std::errc() || end != text.data() + text.size() || v < 0 || v > 232) {
        r.problem("domain", "is -1 (ROS_DOMAIN_ID), whose value \"" + std::string(text) +
                                "\" is not a domain (0 to 232)");
      } else {
        domain = v;
      }
    }
  }
  p.domain = static_cast<std::uint32_t>(domain);
  const std::string distribution = r.string("distribution", "jazzy");
  if (distribution == "humble") {
    out.distribution = Distribution::humble;
  } else if (distribution == "jazzy" || distribution == "iron") {
    out.distribution = Distribution::jazzy;
  } else {
    r.problem("distribution", "must be humble, iron or jazzy");
  }
  out.node = r.string("node", out.node);
  out.ns = r.string("namespace", out.ns);
  if (auto n = resolveRosName(out.node, "/"); !n || out.node.find('/') != std::string::npos) {
    r.problem("node", "not a ROS node name (letters, digits and _)");
  }
  if (!out.ns.starts_with("/") || (out.ns != "/" && !resolveRosName(out.ns, "/"))) {
    r.problem("namespace", "not an absolute ROS namespace (/ or /robot)");
  }
  p.interfaces = r.strings("interfaces", p.interfaces);
  p.peers = r.strings("peers", p.peers);
  if (p.interfaces.empty()) r.problem("interfaces", "names no interface");
  p.allow_non_loopback = false;
  for (const auto& a : p.interfaces) p.allow_non_loopback |= !loopback(a);
  for (const auto& a : p.peers) p.allow_non_loopback |= !loopback(a);
  p.max_participants =
      static_cast<std::uint32_t>(r.integer("max_participants", p.max_participants, 1, 120));
  p.socket_buffer_bytes = static_cast<std::uint32_t>(
      r.integer("socket_buffer_bytes", p.socket_buffer_bytes, 0, 1 << 30));
  p.enclave = "/";
  out.definitions = r.strings("definitions", {});
  out.queue_bytes = static_cast<std::size_t>(
      r.integer("queue_bytes", static_cast<std::int64_t>(out.queue_bytes), 1 << 16, 1ll << 32));

  // The items of one list (`key`), each read by `read` with its own Reader.
  auto each = [&](const char* key, const std::set<std::string>& known, auto read) {
    const Json::Value& v = r.get(key);
    if (v.isNull()) return;
    if (!v.isArray()) {
      r.problem(key, "must be an array of objects");
      return;
    }
    for (Json::ArrayIndex i = 0; i < v.size(); ++i) {
      const std::string path = std::string(key) + "[" + std::to_string(i) + "]";
      Reader item(problems, v[i], path, known);
      read(item, v[i].isObject() ? v[i] : Json::Value(), path);
    }
  };
  // An import's channel is the module's (a short name, by default the ROS name's, unique); an
  // export's is anyone's (a full name).
  std::set<std::string> channels{"status"};
  auto channel = [&](Reader& item, bool import, const std::string& ros, bool may_be_pattern) {
    std::string name = item.string("channel", import ? channelForRosName(ros) : "", !import);
    if (import && !name.empty()) {
      if (!flow::validShortName(name)) {
        item.problem("channel",
                     "not a channel short name (1-128 of A-Z a-z 0-9 _ - ., not first .)");
      } else if (!channels.insert(name).second) {
        item.problem("channel", "\"" + name + "\" is taken (by another import or status)");
      }
    }
    const auto pattern = flow::NamePattern::parse(name);
    if (!import && !name.empty() && name.find('.') == std::string::npos &&
        !(may_be_pattern && pattern && !pattern->isLiteral())) {
      item.problem("channel", "a full channel name, <owner>.<name>");
    }
    return name;
  };
  // A type of `kind` ("msg" or "srv") as "pkg/<kind>/Name".
  auto type = [&](Reader& item, const char* kind) {
    const std::string text = item.string("type", "", true);
    auto full = ros2::fullName(text);
    if (full && full->find(std::string("/") + kind + "/") != std::string::npos) return *full;
    if (!text.empty()) {
      item.problem("type", std::string("not a ROS 2 ") + (kind == std::string("msg")
                                                              ? "message type (pkg/msg/Name)"
                                                              : "service type (pkg/srv/Name)"));
    }
    return std::string();
  };
  auto ros = [&](Reader& item) {
    const std::string text = item.string("ros", "", true);
    if (text.empty()) return std::string();
    auto resolved = resolveRosName(text, out.ns, out.node);
    if (!resolved) {
      item.problem("ros", resolved.error().message);
      return std::string();
    }
    return *resolved;
  };

  // An export's channel that is a pattern (not one name), with the ROS name as a template.
  auto patterned = [&](bool import, const Json::Value& obj) {
    if (import || !obj["channel"].isString()) return false;
    auto p = flow::NamePattern::parse(obj["channel"].asString());
    return p && !p->isLiteral();
  };
  auto rosTemplate = [&](Reader& item) {
    const std::string text = item.string("ros", "", true);
    if (text.empty()) return text;
    if (text.find("{owner}") == std::string::npos && text.find("{name}") == std::string::npos) {
      item.problem("ros",
                   "a pattern's channels need topics of their own: put {owner} and/or {name} in "
                   "it (\"/hub/{owner}/{name}\")");
    } else if (auto r = rosNameForChannel(text, "owner.name", out.ns, out.node); !r) {
      item.problem("ros", r.error().message);
    }
    return text;
  };

  auto topics = [&](const char* key, bool import, std::vector<TopicItem>& list) {
    each(key, {"ros", "type", "channel", "encoding", "qos", "frame_id"},
         [&](Reader& item, const Json::Value& obj, const std::string& path) {
           TopicItem t;
           const bool pattern = patterned(import, obj);
           if (pattern) {
             t.ros = rosTemplate(item);
           } else {
             t.ros = ros(item);
             if (!t.ros.empty()) {
               if (auto dds = ddsTopicName(t.ros); !dds) item.problem("ros", dds.error().message);
             }
           }
           t.type = type(item, "msg");
           const std::string enc = item.string("encoding", "cdr");
           if (enc == "cdr" || enc == "json" || enc == "media") {
             t.encoding = enc == "cdr"    ? Encoding::cdr
                          : enc == "json" ? Encoding::json
                                          : Encoding::media;
           } else {
             item.problem("encoding", "must be cdr, json or media");
           }
           if (t.encoding == Encoding::media && !t.type.empty() && !ros2::isImageType(t.type)) {
             item.problem("encoding",
                          "media carries sensor_msgs/msg/Image and sensor_msgs/msg/CompressedImage "
                          "only (" +
                              t.type + " is cdr or json)");
           }
           t.channel = channel(item, import, t.ros, true);
           if (obj.isMember("frame_id") && (import || t.encoding != Encoding::media)) {
             item.problem("frame_id", "only media exports set a frame_id (the frames have none)");
           }
           // A pattern's items take the matched channel's name when it sets none.
           t.frame_id = item.string("frame_id", pattern ? "" : t.channel);
           if (t.frame_id.find('\0') != std::string::npos) item.problem("frame_id", "has a NUL");
           t.qos = readQos(problems, obj["qos"], path + ".qos", *qosProfile("default"));
           (pattern ? out.export_patterns : list).push_back(std::move(t));
         });
  };
  topics("import", true, out.imports);
  topics("export", false, out.exports);

  auto services = [&](const char* key, bool import, std::vector<ServiceItem>& list) {
    each(key, {"ros", "type", "channel", "command", "timeout_ms"},
         [&](Reader& item, const Json::Value& obj, const std::string&) {
           ServiceItem t;
           t.ros = ros(item);
           if (!t.ros.empty()) {
             if (auto dds = ddsServiceTopics(t.ros); !dds) item.problem("ros", dds.error().message);
           }
           t.type = type(item, "srv");
           t.channel = channel(item, import, t.ros, false);
           t.command = item.string("command", "call");
           if (import && obj.isMember("command")) {
             item.problem("command", "only exported services call a hub service with a command");
           }
           t.timeout_ms = item.integer("timeout_ms", t.timeout_ms, 1, 600000);
           list.push_back(std::move(t));
         });
  };
  services("services_import", true, out.service_imports);
  services("services_export", false, out.service_exports);
  return problems;
}

}  // namespace skr::ros2_bridge
