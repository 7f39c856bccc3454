// SPDX-License-Identifier: Apache-2.0
#include "bridge_config.h"

#include "subject_map.h"

#include <algorithm>
#include <set>

namespace skr::nats_bridge {
namespace {

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
    const std::string path = (key.empty() ? "" : key + ".") + member;
    if (v.isNull()) {
      if (required) problem(path, "is required");
      return def;
    }
    if (!v.isString()) {
      problem(path, "must be a string");
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
  if (!config.isObject()) {
    r.problem("", "must be an object");
    return problems;
  }
  // The host checked the declared keys' types; checked again here for callers without a host.
  auto str = [&](const char* key) { return r.string(config, "", key, false); };
  auto integer = [&](const char* key, int64_t def) {
    const Json::Value& v = config[key];
    if (v.isNull()) return def;
    if (!v.isIntegral()) {
      r.problem(key, "must be an integer");
      return def;
    }
    return v.asInt64();
  };
  ClientOptions& c = out.client;
  c.servers = r.strings(config["servers"], "servers");
  if (c.servers.empty() && problems.empty()) r.problem("servers", "names no server");
  for (size_t i = 0; i < c.servers.size(); ++i) {
    if (c.servers[i].empty()) r.problem("servers[" + std::to_string(i) + "]", "is empty");
  }
  c.user = str("user");
  c.password = str("password");
  c.token = str("token");
  c.creds_file = str("creds_file");
  c.nkey = str("nkey");
  c.nkey_seed_file = str("nkey_seed_file");
  if (c.nkey.empty() != c.nkey_seed_file.empty()) {
    r.problem(c.nkey.empty() ? "nkey" : "nkey_seed_file",
              "is missing: nkey and nkey_seed_file go together");
  }
  c.tls_ca = str("tls_ca");
  c.tls_cert = str("tls_cert");
  c.tls_key = str("tls_key");
  if (c.tls_cert.empty() != c.tls_key.empty()) {
    r.problem(c.tls_cert.empty() ? "tls_cert" : "tls_key",
              "is missing: tls_cert and tls_key go together");
  }
  if (!c.user.empty() && !c.token.empty()) r.problem("token", "give a user or a token, not both");
  c.connect_timeout_ms = integer("connect_timeout_ms", c.connect_timeout_ms);
  c.reconnect_min_ms = integer("reconnect_min_ms", c.reconnect_min_ms);
  c.reconnect_max_ms = integer("reconnect_max_ms", c.reconnect_max_ms);
  if (c.reconnect_max_ms < c.reconnect_min_ms) {
    r.problem("reconnect_max_ms", "is less than reconnect_min_ms");
  }
  c.queue_bytes = static_cast<size_t>(
      std::max<int64_t>(integer("queue_bytes", static_cast<int64_t>(c.queue_bytes)), 0));
  out.request_timeout_ms = integer("request_timeout_ms", out.request_timeout_ms);
  out.queue_group = str("queue_group");

  out.prefix = str("prefix");
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
  if (!imports.isNull() && !imports.isArray()) r.problem("import", "must be an array");
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
    im.service = item["service"].isBool() && item["service"].asBool();
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
    if (!im.as.empty() && !flow::validShortName(im.as)) {
      r.problem(key + ".as", "not a channel short name (1-128 of A-Z a-z 0-9 _ - ., not first .)");
    } else if (!im.as.empty() && (im.as == "status" || !names.insert(im.as).second)) {
      r.problem(key + ".as",
                "\"" + im.as + "\" is taken (by another import or the status channel)");
    }
    out.imports.push_back(std::move(im));
  }

  const Json::Value& kv = config["kv"];
  if (!kv.isNull() && !kv.isArray()) r.problem("kv", "must be an array");
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
