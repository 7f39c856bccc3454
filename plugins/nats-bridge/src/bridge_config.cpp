#include "bridge_config.h"

#include "subject_map.h"

#include <set>

namespace skr::nats_bridge {
namespace {

// A channel's short name, as the hub takes it: 1..128 of A-Z a-z 0-9 _ - . not starting with '.'.
bool validShortName(const std::string& s) {
  if (s.empty() || s.size() > 128 || s[0] == '.') return false;
  for (char c : s) {
    const bool ok = (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') ||
                    c == '_' || c == '-' || c == '.';
    if (!ok) return false;
  }
  return true;
}

bool validBucket(const std::string& s) {
  if (s.empty() || s.size() > 64) return false;
  for (char c : s) {
    const bool ok = (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') ||
                    c == '_' || c == '-';
    if (!ok) return false;
  }
  return true;
}

class Reader {
 public:
  explicit Reader(std::vector<ConfigProblem>& problems) : problems_(problems) {}

  void problem(std::string key, std::string reason) {
    problems_.push_back(ConfigProblem{std::move(key), std::move(reason)});
  }
  std::vector<std::string> strings(const Json::Value& v, const std::string& key) {
    std::vector<std::string> out;
    if (v.isNull()) return out;
    if (!v.isArray()) {
      problem(key, "must be an array of strings");
      return out;
    }
    for (Json::ArrayIndex i = 0; i < v.size(); ++i) {
      if (!v[i].isString()) {
        problem(key + "[" + std::to_string(i) + "]", "must be a string");
      } else {
        out.push_back(v[i].asString());
      }
    }
    return out;
  }
  // Whether `v` is an object; its unknown members are problems.
  bool object(const Json::Value& v, const std::string& key, const std::set<std::string>& known) {
    if (!v.isObject()) {
      problem(key, "must be an object");
      return false;
    }
    for (const auto& member : v.getMemberNames()) {
      if (known.count(member) == 0) problem(key + "." + member, "unknown key");
    }
    return true;  // the known members are still read: every problem is told at once
  }
  std::string string(const Json::Value& obj, const std::string& key, const char* member,
                     bool required, const std::string& def = {}) {
    const Json::Value& v = obj[member];
    if (v.isNull()) {
      if (required) problem(key + "." + member, "is required");
      return def;
    }
    if (!v.isString()) {
      problem(key + "." + member, "must be a string");
      return def;
    }
    return v.asString();
  }

 private:
  std::vector<ConfigProblem>& problems_;
};

}  // namespace

std::vector<ConfigProblem> readConfig(const Json::Value& config, BridgeConfig& out) {
  std::vector<ConfigProblem> problems;
  Reader r(problems);
  ClientOptions& c = out.client;
  c.servers = r.strings(config["servers"], "servers");
  if (c.servers.empty() && problems.empty()) r.problem("servers", "names no server");
  for (size_t i = 0; i < c.servers.size(); ++i) {
    if (c.servers[i].empty()) r.problem("servers[" + std::to_string(i) + "]", "is empty");
  }
  c.user = config["user"].asString();
  c.password = config["password"].asString();
  c.token = config["token"].asString();
  c.creds_file = config["creds_file"].asString();
  c.tls_ca = config["tls_ca"].asString();
  c.tls_cert = config["tls_cert"].asString();
  c.tls_key = config["tls_key"].asString();
  if (c.tls_cert.empty() != c.tls_key.empty()) {
    r.problem(c.tls_cert.empty() ? "tls_key" : "tls_cert", "needs tls_cert and tls_key together");
  }
  if (!c.user.empty() && !c.token.empty()) r.problem("token", "give a user or a token, not both");
  c.connect_timeout_ms = config["connect_timeout_ms"].asInt64();
  c.reconnect_min_ms = config["reconnect_min_ms"].asInt64();
  c.reconnect_max_ms = config["reconnect_max_ms"].asInt64();
  if (c.reconnect_max_ms < c.reconnect_min_ms) {
    r.problem("reconnect_max_ms", "is less than reconnect_min_ms");
  }
  c.queue_bytes = static_cast<size_t>(config["queue_bytes"].asInt64());
  out.request_timeout_ms = config["request_timeout_ms"].asInt64();
  out.queue_group = config["queue_group"].asString();

  out.prefix = config["prefix"].asString();
  if (!out.prefix.empty()) {
    if (auto bad = badSubject(out.prefix, false))
      r.problem("prefix", "not a NATS subject: " + *bad);
  }

  const auto patterns = r.strings(config["export"], "export");
  if (auto filter = flow::NameFilter::parse(patterns); filter) {
    out.exports = std::move(*filter);
  } else {
    r.problem("export", filter.error().message);
  }

  const Json::Value& imports = config["import"];
  std::set<std::string> names;
  for (Json::ArrayIndex i = 0; imports.isArray() && i < imports.size(); ++i) {
    const std::string key = "import[" + std::to_string(i) + "]";
    const Json::Value& item = imports[i];
    if (!r.object(item, key, {"subject", "as", "mime", "service", "timeout_ms"})) continue;
    Import im;
    im.subject = r.string(item, key, "subject", true);
    im.as = r.string(item, key, "as", true);
    im.mime = r.string(item, key, "mime", false, im.mime);
    if (!item["service"].isNull() && !item["service"].isBool()) {
      r.problem(key + ".service", "must be true or false");
    }
    im.service = item["service"].asBool();
    const Json::Value& t = item["timeout_ms"];
    if (!t.isNull() && (!t.isIntegral() || t.asInt64() < 1 || t.asInt64() > 3'600'000)) {
      r.problem(key + ".timeout_ms", "must be an integer from 1 to 3600000");
    } else if (!t.isNull()) {
      im.timeout_ms = t.asInt64();
    }
    if (!im.subject.empty()) {
      if (auto bad = badSubject(im.subject, !im.service)) {
        r.problem(
            key + ".subject",
            "not a NATS subject" + std::string(im.service ? " without wildcards: " : ": ") + *bad);
      }
    }
    if (!im.as.empty() && !validShortName(im.as)) {
      r.problem(key + ".as", "not a channel short name (1-128 of A-Z a-z 0-9 _ - ., not first .)");
    } else if (!im.as.empty() && (im.as == "status" || !names.insert(im.as).second)) {
      r.problem(key + ".as",
                "\"" + im.as + "\" is taken (by another import or the status channel)");
    }
    out.imports.push_back(std::move(im));
  }

  const Json::Value& kv = config["kv"];
  std::set<std::string> buckets;
  for (Json::ArrayIndex i = 0; kv.isArray() && i < kv.size(); ++i) {
    const std::string key = "kv[" + std::to_string(i) + "]";
    const Json::Value& item = kv[i];
    if (!r.object(item, key, {"db", "bucket"})) continue;
    KvMirror m;
    m.db = r.string(item, key, "db", true);
    m.bucket = r.string(item, key, "bucket", false, m.db);
    if (!m.bucket.empty() && !validBucket(m.bucket)) {
      r.problem(key + ".bucket",
                "\"" + m.bucket + "\" is not a bucket name (1-64 of A-Z a-z 0-9 _ -)");
    } else if (!m.bucket.empty() && !buckets.insert(m.bucket).second) {
      r.problem(key + ".bucket", "\"" + m.bucket + "\" is mirrored twice");
    }
    out.kv.push_back(std::move(m));
  }
  return problems;
}

}  // namespace skr::nats_bridge
