// SPDX-License-Identifier: Apache-2.0
#include <skrobot/hub/hub_config.h>

#include "http_head.h"
#include "link_config.h"
#include "satellite_config.h"

#include <arpa/inet.h>
#include <json/reader.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <fstream>
#include <iterator>
#include <map>
#include <memory>
#include <sstream>
#include <system_error>

namespace skr {
namespace {

namespace fs = std::filesystem;
namespace s = schema;

// Names that end up in file names (/tmp/<app_name>, <module>.so): [A-Za-z0-9_.-], not "." or "..".
s::Check plainName(std::string note) {
  return [note = std::move(note)](const Json::Value& v, const std::string& path, s::Problems& out) {
    const std::string name = v.asString();
    for (const char c : name) {
      const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                      c == '_' || c == '.' || c == '-';
      if (!ok) {
        out.push_back({path, "may contain only letters, digits, '_', '.' and '-'" + note +
                                 ", got \"" + name + "\""});
        return;
      }
    }
    if (name == "." || name == "..") out.push_back({path, "must not be \".\" or \"..\""});
  };
}

// sun_path holds 108 bytes, "/tmp/" and the terminating NUL included.
void fitsSocketPath(const Json::Value& v, const std::string& path, s::Problems& out) {
  if (v.asString().size() > 100) {
    out.push_back({path, "must be at most 100 characters (it names the socket /tmp/<app_name>)"});
  }
}

// The top-level loop has defaults; a module's loop has none, so that what it leaves out is
// inherited from the top-level one.
s::Schema loopSchema(bool with_defaults) {
  const auto d = [&](Json::Value v) { return with_defaults ? v : Json::Value(); };
  return s::object({
      s::optional("timing",
                  s::string().oneOf({"coarse", "pseudo-realtime", "socket-driven", "none"}),
                  d("coarse")),
      s::optional("fast_tick_ms", s::number().range(0.1, 1000), d(10)),
      s::optional("slow_tick_ms", s::number(), d(100)),  // >= fast_tick_ms, see readLoop()
      s::optional("load_warning_ratio", s::number().range(0.05, 1), d(0.8)),
      s::optional("busy_poll_us", s::integer().range(0, 100000), d(50)),
  });
}

void absolutePath(const Json::Value& v, const std::string& path, s::Problems& out) {
  if (!v.asString().starts_with("/")) out.push_back({path, "must be an absolute path (/dev/...)"});
}

// server.udp.address: an IPv4 or IPv6 address, never a name (a UDP port is bound explicitly).
void numericAddress(const Json::Value& v, const std::string& path, s::Problems& out) {
  unsigned char buf[16];
  const std::string a = v.asString();
  if (::inet_pton(AF_INET, a.c_str(), buf) != 1 && ::inet_pton(AF_INET6, a.c_str(), buf) != 1) {
    out.push_back({path, "must be a numeric IPv4 or IPv6 address (127.0.0.1, 0.0.0.0, ::)"});
  }
}

void nameOrPath(const Json::Value& m, const std::string& path, s::Problems& out) {
  if (!m.isMember("name") && !m.isMember("path")) {
    out.push_back({path, "needs \"name\" (found on the module search path) or \"path\""});
  }
}

void loopNeedsOwnThread(const Json::Value& m, const std::string& path, s::Problems& out) {
  if (m.isMember("loop") && !m["own_thread"].asBool()) {
    out.push_back(
        {s::childPath(path, "loop"), "applies only to a module with \"own_thread\": true"});
  }
}

s::Schema moduleSchema() {
  return s::object({
                       s::optional("name", s::string().nonEmpty().check(plainName(""))),
                       s::optional("path", s::string().nonEmpty()),
                       s::optional("enabled", s::boolean(), true),
                       s::optional("own_thread", s::boolean(), false),
                       s::optional("account", s::string().nonEmpty()),
                       s::optional("loop", loopSchema(false)),
                       s::optional("config", s::anyObject(), Json::objectValue),
                   })
      .check(nameOrPath)
      .check(loopNeedsOwnThread);
}

// Turns jsoncpp's "* Line 3, Column 7\n  Missing ':' ...\n" into "<origin>:3:7: Missing ':' ...".
std::string syntaxErrors(const std::string& errs, const std::string& origin) {
  std::istringstream in(errs);
  std::string line;
  std::string out;
  while (std::getline(in, line)) {
    int l = 0;
    int c = 0;
    if (std::sscanf(line.c_str(), "* Line %d, Column %d", &l, &c) == 2) {
      out += (out.empty() ? "" : "\n") + origin + ":" + std::to_string(l) + ":" +
             std::to_string(c) + ":";
    } else if (const auto start = line.find_first_not_of(' '); start != std::string::npos) {
      if (out.empty()) out = origin + ":";
      out += " " + line.substr(start);
    }
  }
  return out.empty() ? origin + ": invalid JSON" : out;
}

Result<Json::Value> parseJson(std::string_view text, const std::string& origin) {
  Json::CharReaderBuilder builder;
  builder["collectComments"] = false;
  builder["rejectDupKeys"] = true;
  builder["failIfExtra"] = true;
  const std::unique_ptr<Json::CharReader> reader(builder.newCharReader());
  Json::Value doc;
  std::string errs;
  try {
    if (!reader->parse(text.data(), text.data() + text.size(), &doc, &errs)) {
      return makeError(Errc::config_error, syntaxErrors(errs, origin));
    }
  } catch (const std::exception& e) {  // jsoncpp throws when nesting exceeds its stack limit
    return makeError(Errc::config_error, origin + ": " + e.what());
  }
  return doc;
}

Nanos msToNs(double ms) {
  return static_cast<Nanos>(std::llround(ms * 1e6));
}
double nsToMs(Nanos ns) {
  return static_cast<double>(ns) / 1e6;
}

// Applies the keys present in `obj` over `loop` and checks that slow >= fast. `written` is what
// the user wrote (to say where a value came from); `inherited` names where missing ones came from.
void readLoop(const Json::Value& obj, const Json::Value& written, const std::string& inherited,
              const std::string& path, LoopOptions& loop, s::Problems& out) {
  if (!obj.isObject()) return;
  // The schema already reported what is wrong here; checking further would only repeat it.
  const bool reported = std::any_of(out.begin(), out.end(), [&](const s::Problem& p) {
    return p.path == path || p.path.starts_with(path + ".");
  });
  if (reported) return;
  if (const Json::Value& t = obj["timing"];
      t.isString() && !parseTimingMode(t.asString(), loop.mode)) {
    out.push_back({s::childPath(path, "timing"), "unknown timing mode \"" + t.asString() + "\""});
  }
  const auto number = [&](const char* key, double fallback) {
    return obj[key].isNumeric() ? obj[key].asDouble() : fallback;
  };
  loop.fast_interval_ns = msToNs(number("fast_tick_ms", nsToMs(loop.fast_interval_ns)));
  loop.slow_interval_ns = msToNs(number("slow_tick_ms", nsToMs(loop.slow_interval_ns)));
  loop.load_warning_ratio = number("load_warning_ratio", loop.load_warning_ratio);
  loop.busy_poll_ns = static_cast<Nanos>(
      number("busy_poll_us", static_cast<double>(loop.busy_poll_ns) / 1000.0) * 1000.0);
  if (loop.slow_interval_ns >= loop.fast_interval_ns) return;
  const auto given = [&](const char* key) { return written.isObject() && written.isMember(key); };
  const std::string fast = s::formatNumber(nsToMs(loop.fast_interval_ns));
  const std::string slow = s::formatNumber(nsToMs(loop.slow_interval_ns));
  out.push_back({s::childPath(path, "slow_tick_ms"),
                 "must be >= fast_tick_ms (" + fast +
                     (given("fast_tick_ms") ? "" : ", " + inherited) + "), got " + slow +
                     (given("slow_tick_ms") ? "" : " (" + inherited + ")")});
}

// "libcamera.so" and "camera.so.1" are both "camera".
std::string nameFromPath(const fs::path& file) {
  std::string name = file.filename().string();
  if (const auto so = name.find(".so");
      so != std::string::npos && (so + 3 == name.size() || name[so + 3] == '.')) {
    name.resize(so);
  }
  if (name.size() > 3 && name.starts_with("lib")) name.erase(0, 3);
  return name;
}

fs::path resolve(const fs::path& base_dir, const std::string& text) {
  const fs::path p(text);
  return (p.is_absolute() ? p : base_dir / p).lexically_normal();
}

void readModules(const Json::Value& list, const fs::path& base_dir, HubConfig& cfg,
                 s::Problems& out) {
  std::map<std::string, const ModuleEntry*> enabled;  // name -> first enabled entry
  cfg.modules.reserve(list.size());
  for (Json::ArrayIndex i = 0; list.isArray() && i < list.size(); ++i) {
    const Json::Value& m = list[i];
    if (!m.isObject()) continue;
    ModuleEntry e;
    e.json_path = s::indexPath("$.modules", i);
    if (m["name"].isString()) e.name = m["name"].asString();
    if (m["path"].isString() && !m["path"].asString().empty()) {
      e.path = resolve(base_dir, m["path"].asString());
      if (e.name.empty()) e.name = nameFromPath(e.path);
      if (e.name.empty()) out.push_back({s::childPath(e.json_path, "path"), "names no file"});
    }
    if (m["enabled"].isBool()) e.enabled = m["enabled"].asBool();
    if (m["own_thread"].isBool()) e.own_thread = m["own_thread"].asBool();
    if (m["account"].isString()) e.account = m["account"].asString();
    if (m["config"].isObject()) e.config = m["config"];
    e.loop = cfg.loop;
    e.loop.name = e.name;
    readLoop(m["loop"], m["loop"], "inherited from $.loop", s::childPath(e.json_path, "loop"),
             e.loop, out);
    cfg.modules.push_back(std::move(e));
  }
  for (const ModuleEntry& e : cfg.modules) {
    if (!e.enabled || e.name.empty()) continue;
    const auto [it, inserted] = enabled.emplace(e.name, &e);
    if (inserted) continue;
    const auto where = [](const ModuleEntry& x) {
      return x.json_path + (x.path.empty() ? "" : " (" + x.path.string() + ")");
    };
    out.push_back({e.json_path, "duplicate module name \"" + e.name + "\": " + where(*it->second) +
                                    " and " + where(e) + " are both enabled"});
  }
}

// A serial port (docs/microcontrollers.md): the rate is checked when the port opens.
s::Schema serialSchema() {
  return s::object({
      s::required("device", s::string().nonEmpty().check(absolutePath)),
      s::optional("baud", s::integer().range(50, 4000000), 115200),
      s::optional("account", s::string(), ""),
      s::optional("max_frame", s::integer().range(64, 65536), 4096),
      s::optional("queue_bytes", s::integer().range(256, 1 << 20), 4096),
      s::optional("pace", s::integer().range(0, 1 << 22), 0),
  });
}

// server.web.mounts: {"/teleop": "examples/teleop"}. A key is a URL path prefix of plain
// segments; the two paths the web port answers itself cannot be mounts.
void webMounts(const Json::Value& v, const std::string& path, s::Problems& out) {
  for (const std::string& key : v.getMemberNames()) {
    const std::string where = s::childPath(path, key);
    if (!v[key].isString() || v[key].asString().empty()) {
      out.push_back({where, "must be a directory (a non-empty string)"});
    }
    if (!flow::http::isPathPrefix(key)) {
      out.push_back({where,
                     "must be a URL path prefix: '/' then segments of letters, digits, '_', '.', "
                     "'-', '~' (not \".\" or \"..\"), no trailing '/' (\"/teleop\")"});
    } else if (key == "/flow" || key == "/skrobot/token") {
      out.push_back({where, "is answered by the web port itself and cannot be a mount"});
    }
  }
}

// server.web.origins: "http://host[:port]" or "https://host[:port]", as a browser sends Origin.
void webOrigin(const Json::Value& v, const std::string& path, s::Problems& out) {
  const std::string o = v.asString();
  const size_t sep = o.find("://");
  const std::string scheme = sep == std::string::npos ? "" : o.substr(0, sep);
  const std::string rest = sep == std::string::npos ? "" : o.substr(sep + 3);
  const bool ok = (scheme == "http" || scheme == "https") && !rest.empty() &&
                  rest.find_first_of("/?#@ ") == std::string::npos &&
                  std::none_of(o.begin(), o.end(), [](char c) { return c >= 'A' && c <= 'Z'; });
  if (!ok) {
    out.push_back({path,
                   "must be an origin as browsers send it, lower case: "
                   "\"http://host[:port]\" or \"https://host[:port]\", got \"" +
                       o + "\""});
  }
}

// server.web.hosts: names a Host header may carry (without its port).
void webHost(const Json::Value& v, const std::string& path, s::Problems& out) {
  const std::string h = v.asString();
  const bool ok = std::all_of(h.begin(), h.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '.' || c == '-';
  });
  if (!ok) {
    out.push_back({path, "must be a lower-case host name without a port (\"robot.local\"), got \"" +
                             h + "\""});
  }
}

s::Schema webSchema() {
  return s::object({
      s::optional("address", s::string().nonEmpty(), "127.0.0.1"),
      s::optional("port", s::integer().range(0, 65535), 8080),
      s::optional("root", s::string(), ""),
      s::optional("mounts", s::anyObject().check(webMounts), Json::objectValue),
      s::optional("flows", s::boolean(), false),
      s::optional("origins", s::arrayOf(s::string().check(webOrigin)), Json::arrayValue),
      s::optional("hosts", s::arrayOf(s::string().nonEmpty().check(webHost)), Json::arrayValue),
      s::optional("page_account", s::string().nonEmpty(), "web-page"),
      s::optional("token_ttl_ms", s::integer().range(100, 86400000), 60000),
      s::optional("dev_account", s::boolean(), false),
  });
}

s::Schema serverSchema() {
  return s::object({
      s::optional("unix_socket", s::boolean(), true),
      s::optional("unix_path", s::string(), ""),
      s::optional("tcp", s::boolean(), false),
      s::optional("tcp_address", s::string().nonEmpty(), "127.0.0.1"),
      s::optional("tcp_port", s::integer().range(0, 65535), 9000),
      s::optional("tls", s::object({
                             s::required("cert", s::string().nonEmpty()),
                             s::required("key", s::string().nonEmpty()),
                             s::optional("client_ca", s::string(), ""),
                             s::optional("min_version", s::string().oneOf({"1.2", "1.3"}), "1.2"),
                         })),
      s::optional("serial", s::arrayOf(serialSchema()), Json::arrayValue),
      // Boards' UDP sessions (docs/microcontrollers.md): off unless set, the address explicit.
      s::optional("udp",
                  s::object({
                      s::required("address", s::string().nonEmpty().check(numericAddress)),
                      s::optional("port", s::integer().range(0, 65535), 9001),
                      s::optional("max_datagram", s::integer().range(128, 65507), 1200),
                      s::optional("session_timeout_ms", s::integer().range(100, 3600000), 10000),
                  })),
      // The hub's web port (files, page tokens, flows over WebSocket): off unless set.
      s::optional("web", webSchema()),
      s::optional("max_frame_bytes", s::integer().range(1024, 1 << 30), 16 << 20),
      s::optional("subscriber_queue_bytes", s::integer().range(64 << 10, 1 << 30), 8 << 20),
      s::optional("subscriber_queue_max_bytes", s::integer().range(64 << 10, 1 << 30), 64 << 20),
      s::optional("max_connections", s::integer().range(1, 100000), 1024),
      s::optional("login_timeout_ms", s::integer().range(100, 600000), 5000),
      s::optional("max_pending_requests", s::integer().range(1, 1000000), 1024),
      s::optional("request_timeout_ms", s::integer().range(10, 86400000), 30000),
      s::optional("user_limits",
                  s::object({s::optional("connections", s::integer().range(1, 100000), 64),
                             s::optional("channels", s::integer().range(1, 32767), 1024),
                             s::optional("databases", s::integer().range(1, 100000), 64),
                             s::optional("pending_requests", s::integer().range(1, 1000000), 1024),
                             s::optional("blob_mib", s::integer().range(0, 100000000), 0),
                             s::optional("blob_files", s::integer().range(0, 100000000), 0)})),
  });
}

s::Schema accountsSchema() {
  return s::object({
      s::optional("users_file", s::string(), ""),
      s::optional("dev_account", s::object({s::required("user", s::string().nonEmpty()),
                                            s::required("password", s::string().nonEmpty())})),
  });
}

fs::path defaultDataDir(const std::string& app_name) {
  if (const char* x = std::getenv("XDG_DATA_HOME"); x != nullptr && *x == '/') {
    return fs::path(x) / "skrobot" / app_name;
  }
  const char* home = std::getenv("HOME");
  return fs::path(home != nullptr && *home != '\0' ? home : "/tmp") / ".local/share/skrobot" /
         app_name;
}

void readServer(const Json::Value& d, const fs::path& base_dir, HubConfig& cfg) {
  const Json::Value& s = d["server"];
  ServerConfig& out = cfg.server;
  if (s.isObject()) {
    out.unix_enabled = s["unix_socket"].asBool();
    out.unix_path = s["unix_path"].asString();
    if (!out.unix_path.empty()) out.unix_path = resolve(base_dir, out.unix_path).string();
    out.tcp_enabled = s["tcp"].asBool();
    out.tcp_address = s["tcp_address"].asString();
    out.tcp_port = static_cast<uint16_t>(s["tcp_port"].asInt());
    if (const Json::Value& t = s["tls"]; t.isObject()) {
      flow::TlsSettings tls;
      tls.cert_file = resolve(base_dir, t["cert"].asString()).string();
      tls.key_file = resolve(base_dir, t["key"].asString()).string();
      if (!t["client_ca"].asString().empty()) {
        tls.ca_file = resolve(base_dir, t["client_ca"].asString()).string();
      }
      tls.min_version = t["min_version"].asString();
      out.tls = std::move(tls);
    }
    for (const Json::Value& p : s["serial"]) {
      flow::transport::SerialOptions port;
      port.device = p["device"].asString();
      port.baud = p["baud"].asUInt();
      port.account = p["account"].asString();
      port.max_frame = p["max_frame"].asUInt();
      port.queue_bytes = p["queue_bytes"].asUInt();
      port.pace = p["pace"].asUInt();
      out.serial.push_back(std::move(port));
    }
    if (const Json::Value& u = s["udp"]; u.isObject()) {
      flow::transport::UdpOptions udp;
      udp.address = u["address"].asString();
      udp.port = static_cast<uint16_t>(u["port"].asUInt());
      udp.max_datagram = u["max_datagram"].asUInt();
      udp.session_timeout_ms = u["session_timeout_ms"].asUInt();
      out.udp = std::move(udp);
    }
    if (const Json::Value& w = s["web"]; w.isObject()) {
      flow::WebOptions web;
      web.address = w["address"].asString();
      web.port = static_cast<uint16_t>(w["port"].asUInt());
      if (!w["root"].asString().empty()) web.root = resolve(base_dir, w["root"].asString());
      for (const std::string& prefix : w["mounts"].getMemberNames()) {
        if (!w["mounts"][prefix].isString()) continue;  // reported by the schema
        web.mounts.emplace_back(prefix, resolve(base_dir, w["mounts"][prefix].asString()));
      }
      web.flows = w["flows"].asBool();
      for (const Json::Value& o : w["origins"]) web.origins.push_back(o.asString());
      for (const Json::Value& h : w["hosts"]) web.hosts.push_back(h.asString());
      web.page_account = w["page_account"].asString();
      web.token_ttl_ms = w["token_ttl_ms"].asUInt();
      web.dev_account = w["dev_account"].asBool();
      out.web = std::move(web);
    }
    out.max_frame_bytes = s["max_frame_bytes"].asUInt();
    out.subscriber_queue_bytes = s["subscriber_queue_bytes"].asUInt();
    out.subscriber_queue_max_bytes = s["subscriber_queue_max_bytes"].asUInt();
    out.max_connections = s["max_connections"].asUInt();
    out.login_timeout_ms = s["login_timeout_ms"].asUInt();
    out.max_pending_requests = s["max_pending_requests"].asUInt();
    out.request_timeout_ms = s["request_timeout_ms"].asUInt();
    const Json::Value& l = s["user_limits"];
    const auto limit = [&l](const char* key, uint32_t def) {
      return l.isObject() && l[key].isUInt() ? l[key].asUInt() : def;
    };
    out.user_limits = {limit("connections", 64), limit("channels", 1024),
                       limit("databases", 64),   limit("pending_requests", 1024),
                       limit("blob_mib", 0),     limit("blob_files", 0)};
  }
  const std::string data_dir = d["data_dir"].isString() ? d["data_dir"].asString() : "";
  out.data_dir = data_dir.empty() ? defaultDataDir(cfg.app_name) : resolve(base_dir, data_dir);
  if (const Json::Value& db = d["databases"]; db.isObject()) {
    const std::string durability = db["durability"].asString();
    out.durability = durability == "always" ? flow::Durability::always
                     : durability == "no"   ? flow::Durability::no
                                            : flow::Durability::everysec;
    out.compact_bytes = db["compact_bytes"].asUInt64();
  }
  if (const Json::Value& b = d["blobs"]; b.isObject()) {
    out.blob_channel_bytes = b["max_channel_mib"].asUInt64() << 20;
    out.blob_channel_files = b["max_channel_files"].asUInt64();
    out.blob_io_threads = b["io_threads"].asUInt();
  }
  const Json::Value& a = d["accounts"];
  const std::string users =
      a.isObject() && a["users_file"].isString() ? a["users_file"].asString() : "";
  out.users_file = users.empty() ? out.data_dir / "users.json" : resolve(base_dir, users);
  if (a.isObject() && a["dev_account"].isObject()) {
    out.dev_account = std::make_pair(a["dev_account"]["user"].asString(),
                                     a["dev_account"]["password"].asString());
  }
}

Result<HubConfig> build(const Json::Value& doc, const std::string& origin, const fs::path& base_dir,
                        ConfigPurpose purpose) {
  const s::Schema schema = hubSchema();
  s::Problems problems = s::validate(doc, schema);
  HubConfig cfg;
  cfg.raw = s::withDefaults(doc, schema);
  const Json::Value& d = cfg.raw;
  if (d.isObject()) {
    if (d["app_name"].isString()) cfg.app_name = d["app_name"].asString();
    if (d["log"].isObject() && d["log"]["level"].isString()) {
      log::parseLevel(d["log"]["level"].asString(), cfg.log_level);
    }
    readLoop(d["loop"], doc["loop"], "the default", "$.loop", cfg.loop, problems);
    for (Json::ArrayIndex i = 0; d["module_paths"].isArray() && i < d["module_paths"].size(); ++i) {
      const Json::Value& p = d["module_paths"][i];
      if (p.isString() && !p.asString().empty()) {
        cfg.module_paths.push_back(resolve(base_dir, p.asString()));
      }
    }
    readModules(d["modules"], base_dir, cfg, problems);
    if (d["sync"].isObject()) cfg.sync_hub_source = d["sync"]["hub_source"].asString();
    readServer(d, base_dir, cfg);
    readLinks(d, base_dir, purpose, cfg, problems);
    readSatellites(d, base_dir, cfg, problems);
    if (cfg.server.tls && !cfg.server.tcp_enabled && !cfg.server.web) {
      problems.push_back({"$.server.tls",
                          "TLS is served on the TCP listener and the web port: set \"tcp\": true "
                          "or \"web\""});
    }
    if (cfg.server.web && cfg.server.web->dev_account && !cfg.server.dev_account) {
      problems.push_back({"$.server.web.dev_account",
                          "lets the development account in over WebSocket from this machine, but "
                          "$.accounts.dev_account sets none"});
    }
  }
  if (!problems.empty()) return makeError(Errc::config_error, s::formatProblems(problems, origin));
  return cfg;
}

}  // namespace

s::Schema hubSchema() {
  // One line per top-level section.
  return s::object({
      s::optional("app_name",
                  s::string()
                      .nonEmpty()
                      .check(plainName(" (it names the socket /tmp/<app_name>)"))
                      .check(fitsSocketPath),
                  "Robot"),
      s::optional("log",
                  s::object({s::optional(
                      "level", s::string().oneOf({"debug", "info", "warn", "error"}), "info")}),
                  Json::objectValue),
      s::optional("loop", loopSchema(true), Json::objectValue),
      s::optional("module_paths", s::arrayOf(s::string().nonEmpty()), Json::arrayValue),
      s::optional("modules", s::arrayOf(moduleSchema()), Json::arrayValue),
      s::optional("data_dir", s::string(), ""),
      s::optional(
          "databases",
          s::object({s::optional("durability", s::string().oneOf({"always", "everysec", "no"}),
                                 "everysec"),
                     s::optional("compact_bytes", s::integer().range(4096, 1 << 30), 4 << 20)}),
          Json::objectValue),
      s::optional("blobs",
                  s::object({s::optional("max_channel_mib", s::integer().range(0, 100000000), 0),
                             s::optional("max_channel_files", s::integer().range(0, 100000000), 0),
                             s::optional("io_threads", s::integer().range(0, 16), 1)}),
                  Json::objectValue),
      s::optional("server", serverSchema(), Json::objectValue),
      s::optional("sync",
                  s::object({s::optional("hub_source", s::string().check(plainName("")), "")}),
                  Json::objectValue),
      s::optional("accounts", accountsSchema(), Json::objectValue),
      s::optional("hub_name", hubNameSchema()),
      s::optional("links", linksSchema(), Json::arrayValue),
      s::optional("link_hops", linkHopsSchema(), 8),
      s::optional("replicas", replicasSchema(), Json::arrayValue),
      s::optional("satellites", satellitesSchema(), Json::arrayValue),
  });
}

Result<HubConfig> parseHubConfig(std::string_view text, const std::string& origin,
                                 const fs::path& base_dir, ConfigPurpose purpose) {
  try {
    Result<Json::Value> doc = parseJson(text, origin);
    if (!doc) return doc.error();
    std::error_code ec;
    const fs::path dir = fs::absolute(base_dir, ec);
    return build(*doc, origin, ec ? base_dir : dir, purpose);
  } catch (const std::exception& e) {  // a bug here must not take the hub down with it
    return makeError(Errc::exception, origin + ": " + e.what());
  }
}

Result<HubConfig> loadHubConfig(const fs::path& file, ConfigPurpose purpose) {
  const std::string origin = file.string();
  std::error_code ec;
  if (!fs::exists(file, ec)) return makeError(Errc::not_found, origin + ": no such file");
  if (fs::is_directory(file, ec)) return makeError(Errc::io_error, origin + ": is a directory");
  std::ifstream in(file, std::ios::binary);
  const std::string text{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  if (!in.is_open() || in.bad()) return makeError(Errc::io_error, origin + ": cannot read");
  const fs::path absolute = fs::absolute(file, ec).lexically_normal();
  Result<HubConfig> cfg = parseHubConfig(text, origin, absolute.parent_path(), purpose);
  if (cfg) cfg->config_file = absolute;
  return cfg;
}

}  // namespace skr
