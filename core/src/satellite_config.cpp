// SPDX-License-Identifier: Apache-2.0
// "satellites" (see satellite_config.h).
#include "satellite_config.h"

#include <algorithm>
#include <cctype>
#include <csignal>
#include <functional>
#include <map>
#include <set>

namespace skr {
namespace {

namespace fs = std::filesystem;
namespace s = schema;

constexpr std::pair<std::string_view, int> kStopSignals[] = {
    {"SIGTERM", SIGTERM}, {"SIGINT", SIGINT},   {"SIGHUP", SIGHUP},   {"SIGQUIT", SIGQUIT},
    {"SIGUSR1", SIGUSR1}, {"SIGUSR2", SIGUSR2}, {"SIGKILL", SIGKILL},
};

// A satellite's name is its log source (sat.<name>) and a word of flowctl's commands.
void satelliteName(const Json::Value& v, const std::string& path, s::Problems& out) {
  const std::string name = v.asString();
  for (const char c : name) {
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_' && c != '-') {
      out.push_back({path, "may contain only letters, digits, '_' and '-', got \"" + name + "\""});
      return;
    }
  }
}

void envStrings(const Json::Value& v, const std::string& path, s::Problems& out) {
  for (const std::string& key : v.getMemberNames()) {
    const bool ok = !key.empty() && key.find('=') == std::string::npos &&
                    !std::isdigit(static_cast<unsigned char>(key[0]));
    if (!ok) out.push_back({s::childPath(path, key), "is not an environment variable's name"});
    if (!v[key].isString()) out.push_back({s::childPath(path, key), "expected string"});
  }
}

fs::path resolve(const fs::path& base_dir, const std::string& text) {
  const fs::path p(text);
  return (p.is_absolute() ? p : base_dir / p).lexically_normal();
}

// Circles through `after` among satellites: each reported once, at the first member's path.
void findCircles(const std::vector<SatelliteEntry>& sats, s::Problems& out) {
  std::map<std::string, const SatelliteEntry*> by_name;
  for (const auto& e : sats) by_name.emplace(e.name, &e);
  std::map<std::string, int> mark;  // 1: on the path, 2: done
  std::function<bool(const SatelliteEntry&, std::string&)> visit = [&](const SatelliteEntry& e,
                                                                       std::string& trail) {
    mark[e.name] = 1;
    for (const auto& a : e.after) {
      auto it = by_name.find(a);
      if (it == by_name.end()) continue;
      if (mark[a] == 1) {
        trail = a;
        return true;
      }
      if (mark[a] == 0 && visit(*it->second, trail)) {
        trail = a + " -> " + trail;
        return true;
      }
    }
    mark[e.name] = 2;
    return false;
  };
  for (const auto& e : sats) {
    std::string trail;
    if (mark[e.name] == 0 && visit(e, trail)) {
      out.push_back({s::childPath(e.json_path, "after"),
                     "a circle: " + e.name + " -> " + trail + " (each waits for the other)"});
    }
  }
}

}  // namespace

int stopSignalNumber(std::string_view name) {
  for (const auto& [n, number] : kStopSignals) {
    if (n == name) return number;
  }
  return 0;
}

s::Schema satellitesSchema() {
  std::vector<std::string> signals;
  for (const auto& [n, number] : kStopSignals) signals.emplace_back(n);
  return s::arrayOf(s::object({
      s::required("name", s::string().nonEmpty().check(satelliteName)),
      s::required("command", s::arrayOf(s::string().nonEmpty()).items(1, 1024)),
      s::optional("env", s::anyObject().check(envStrings)),
      s::optional("cwd", s::string().nonEmpty()),
      s::optional("account", s::string().nonEmpty()),
      s::optional("restart", s::string().oneOf({"always", "on-failure", "never"}), "on-failure"),
      s::optional("backoff_ms", s::integer().range(10, 3600000), 1000),
      s::optional("max_backoff_ms", s::integer().range(10, 3600000), 30000),
      s::optional("max_restarts_per_minute", s::integer().range(1, 1000), 5),
      s::optional("after", s::arrayOf(s::string().nonEmpty()), Json::arrayValue),
      s::optional("ready", s::string().nonEmpty()),
      s::optional("ready_timeout_ms", s::integer().range(100, 3600000), 30000),
      s::optional("stop_signal", s::string().oneOf(signals), "SIGTERM"),
      s::optional("grace_ms", s::integer().range(0, 600000), 5000),
      s::optional("limits",
                  s::object({s::optional("memory_mib", s::integer().range(1, 1 << 24)),
                             s::optional("open_files", s::integer().range(16, 1 << 20)),
                             s::optional("nice", s::integer().range(0, 19), 0)}),
                  Json::objectValue),
      s::optional("log_lines_per_second", s::integer().range(1, 100000), 100),
      s::optional("enabled", s::boolean(), true),
  }));
}

void readSatellites(const Json::Value& d, const fs::path& base_dir, HubConfig& cfg,
                    s::Problems& problems) {
  const Json::Value& list = d["satellites"];
  if (!list.isArray()) return;
  std::set<std::string> names;
  for (Json::ArrayIndex i = 0; i < list.size(); ++i) {
    const Json::Value& j = list[i];
    if (j.isObject() && j["name"].isString()) names.insert(j["name"].asString());
  }
  std::set<std::string> seen;
  for (Json::ArrayIndex i = 0; i < list.size(); ++i) {
    const Json::Value& j = list[i];
    const std::string path = s::indexPath("$.satellites", i);
    if (!j.isObject() || !j["name"].isString() || !j["command"].isArray()) continue;
    SatelliteEntry e;
    e.json_path = path;
    e.name = j["name"].asString();
    if (!seen.insert(e.name).second) {
      problems.push_back({s::childPath(path, "name"), "satellite " + e.name + " is named twice"});
    }
    for (const Json::Value& c : j["command"]) e.command.push_back(c.asString());
    if (!e.command.empty() && e.command[0].find('/') != std::string::npos) {
      e.command[0] = resolve(base_dir, e.command[0]).string();
    }
    for (const std::string& key : j["env"].getMemberNames()) {
      e.env.emplace_back(key, j["env"][key].asString());
    }
    e.cwd = j["cwd"].isString() ? resolve(base_dir, j["cwd"].asString()) : base_dir;
    e.account = j["account"].asString();
    const std::string restart = j["restart"].asString();
    e.restart = restart == "always"  ? SatelliteEntry::Restart::always
                : restart == "never" ? SatelliteEntry::Restart::never
                                     : SatelliteEntry::Restart::on_failure;
    e.backoff_ms = j["backoff_ms"].asUInt();
    e.max_backoff_ms = std::max(e.backoff_ms, j["max_backoff_ms"].asUInt());
    e.max_restarts_per_minute = j["max_restarts_per_minute"].asUInt();
    for (const Json::Value& a : j["after"]) {
      const std::string name = a.asString();
      e.after.push_back(name);
      if (name.find('.') != std::string::npos) continue;  // a channel
      if (name == e.name) {
        problems.push_back({s::childPath(path, "after"), "names the satellite itself"});
      } else if (names.count(name) == 0) {
        problems.push_back({s::childPath(path, "after"),
                            "no satellite " + name + " (a channel's name has a '.')"});
      }
    }
    e.ready = j["ready"].isString() ? j["ready"].asString() : "started";
    if (e.ready != "login" && e.ready != "started" && e.ready.find('.') == std::string::npos) {
      problems.push_back(
          {s::childPath(path, "ready"),
           "expected \"started\", \"login\" or a channel's name (user.name), got \"" + e.ready +
               "\""});
    }
    e.ready_timeout_ms = j["ready_timeout_ms"].asUInt();
    e.stop_signal = stopSignalNumber(j["stop_signal"].asString());
    e.grace_ms = j["grace_ms"].asUInt();
    const Json::Value& limits = j["limits"];
    e.memory_bytes = limits["memory_mib"].asUInt64() << 20;
    e.open_files = limits["open_files"].asUInt();
    e.nice = limits["nice"].asInt();
    e.log_lines_per_second = j["log_lines_per_second"].asUInt();
    e.enabled = j["enabled"].asBool();
    for (const auto& [key, value] : e.env) {
      if (key == "ROBOT_USER" || key == "ROBOT_PASSWORD") {
        problems.push_back({s::childPath(s::childPath(path, "env"), key),
                            "the hub sets it: the satellite logs in as its \"account\" (or its "
                            "name) with a password made for each run"});
      }
    }
    cfg.satellites.push_back(std::move(e));
  }
  findCircles(cfg.satellites, problems);
}

}  // namespace skr
