// SPDX-License-Identifier: Apache-2.0
// "hub_name" and "links" (see link_config.h).
#include "link_config.h"

#include <skrobot/hub/flow/pair_database.h>
#include <skrobot/runtime/flow/address.h>

#include <sys/stat.h>

#include <cstdlib>
#include <fstream>
#include <set>

namespace skr {
namespace {

namespace fs = std::filesystem;
namespace s = schema;

void hubNameCheck(const Json::Value& v, const std::string& path, s::Problems& out) {
  if (!flow::validHubName(v.asString())) {
    out.push_back({path, "a hub name is 1 to 64 of A-Z a-z 0-9 _ -, got \"" + v.asString() + "\""});
  }
}

bool loopbackHost(const std::string& host) {
  return host == "localhost" || host == "::1" || host.starts_with("127.");
}

// The password of a link: the first line of its file (readable by its owner only), or an
// environment variable; never the config itself.
std::string readPassword(const Json::Value& l, const fs::path& base_dir, const std::string& path,
                         ConfigPurpose purpose, HubConfig& cfg, s::Problems& out) {
  const bool file = l.isMember("password_file");
  const bool env = l.isMember("password_env");
  if (file == env) {
    out.push_back({path, "needs one of \"password_file\" and \"password_env\""});
    return {};
  }
  if (env) {
    const std::string var = l["password_env"].asString();
    const char* value = std::getenv(var.c_str());
    if (value == nullptr || *value == '\0') {
      if (purpose == ConfigPurpose::check) {
        cfg.notes.push_back({s::childPath(path, "password_env"),
                             "the variable " + var +
                                 " is not set here: the hub's environment must set it at start"});
      } else {
        out.push_back({s::childPath(path, "password_env"), "the variable " + var + " is not set"});
      }
      return {};
    }
    return value;
  }
  fs::path p = l["password_file"].asString();
  if (p.is_relative()) p = base_dir / p;
  struct stat st {};
  if (::stat(p.c_str(), &st) != 0) {
    out.push_back({s::childPath(path, "password_file"), p.string() + ": no such file"});
    return {};
  }
  if ((st.st_mode & 077) != 0) {
    out.push_back({s::childPath(path, "password_file"),
                   p.string() + " may be read by others: chmod 600 " + p.string()});
    return {};
  }
  std::ifstream in(p);
  std::string line;
  std::getline(in, line);
  if (!line.empty() && line.back() == '\r') line.pop_back();
  if (line.empty()) {
    out.push_back({s::childPath(path, "password_file"), p.string() + " is empty"});
  }
  return line;
}

}  // namespace

s::Schema hubNameSchema() {
  return s::string().check(hubNameCheck);
}

s::Schema replicasSchema() {
  return s::arrayOf(s::object({
      s::required("from", s::string().nonEmpty()),
      s::required("as", s::string().nonEmpty()),
  }));
}

s::Schema linkHopsSchema() {
  return s::integer().range(1, 64);
}

s::Schema linksSchema() {
  return s::arrayOf(s::object({
      s::required("name", s::string().check(hubNameCheck)),
      s::required("address", s::string().nonEmpty()),
      s::required("user", s::string().nonEmpty()),
      s::optional("password_file", s::string().nonEmpty()),
      s::optional("password_env", s::string().nonEmpty()),
      s::optional("max_channels", s::integer().range(1, 32767), 4096),
      s::optional("account", s::string().nonEmpty()),
      s::optional("tls", s::object({s::optional("ca_file", s::string(), ""),
                                    s::optional("cert_file", s::string(), ""),
                                    s::optional("key_file", s::string(), "")})),
  }));
}

void readLinks(const Json::Value& d, const fs::path& base_dir, ConfigPurpose purpose,
               HubConfig& cfg, s::Problems& problems) {
  if (d["hub_name"].isString()) cfg.hub_name = d["hub_name"].asString();
  if (d["link_hops"].isUInt()) cfg.link_hops = d["link_hops"].asUInt();
  for (Json::ArrayIndex i = 0; d["replicas"].isArray() && i < d["replicas"].size(); ++i) {
    const Json::Value& r = d["replicas"][i];
    if (r.isObject() && r["from"].isString() && r["as"].isString()) {
      cfg.replicas.push_back({r["from"].asString(), r["as"].asString()});
    }
  }
  const Json::Value& links = d["links"];
  if (!links.isArray()) return;
  std::set<std::string> names;
  for (Json::ArrayIndex i = 0; i < links.size(); ++i) {
    const Json::Value& l = links[i];
    const std::string path = s::indexPath("$.links", i);
    if (!l.isObject() || !l["name"].isString() || !l["address"].isString()) continue;
    flow::HubLinkOptions o;
    o.name = l["name"].asString();
    o.address = l["address"].asString();
    o.user = l["user"].asString();
    o.max_channels = l["max_channels"].asUInt();
    if (l["account"].isString()) o.account = l["account"].asString();
    if (!names.insert(o.name).second) {
      problems.push_back({s::childPath(path, "name"), "hub " + o.name + " is linked twice"});
    }
    if (o.name == cfg.hub_name) {
      problems.push_back({s::childPath(path, "name"), "is this hub's own hub_name"});
    }
    auto address = flow::Address::parse(o.address);
    if (!address) {
      problems.push_back({s::childPath(path, "address"), address.error().message});
    } else if (address->kind == flow::Address::Kind::tcp && !loopbackHost(address->host)) {
      problems.push_back({s::childPath(path, "address"),
                          "a link over TCP to another machine needs TLS: tls:" + address->host +
                              ":" + std::to_string(address->port)});
    }
    if (const Json::Value& t = l["tls"]; t.isObject()) {
      const auto file = [&](const char* key) {
        const std::string v = t[key].asString();
        return v.empty() ? v : (fs::path(v).is_relative() ? base_dir / v : fs::path(v)).string();
      };
      o.tls.ca_file = file("ca_file");
      o.tls.cert_file = file("cert_file");
      o.tls.key_file = file("key_file");
    }
    o.password = readPassword(l, base_dir, path, purpose, cfg, problems);
    cfg.links.push_back(std::move(o));
  }
}

}  // namespace skr
