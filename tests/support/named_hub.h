// SPDX-License-Identifier: Apache-2.0
// A hub process with a hub name, linked to other hubs (docs/hub-links.md), for the hub-link
// tests: its own directory, app name and socket; the development account on every link.
#pragma once

#include <sys/stat.h>

#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "sat_fixture.h"

namespace skr::sat::test {

// A hub named `name` in its own directory, linking with the development account to the hubs
// added by link(); its config is written by start().
struct NamedHub {
  explicit NamedHub(std::string hub_name) : name(std::move(hub_name)) {}
  // A link to `to`, at its address or at `via` (a path that leads there later, say).
  NamedHub& link(NamedHub& to, std::string via = {}) {
    links.push_back(&to);
    vias.push_back(std::move(via));
    return *this;
  }
  [[nodiscard]] std::string address() const {
    return "local:" + (dir.path() / "hub.sock").string();
  }
  bool start() {
    if (!hub) {
      std::string keys = R"("hub_name": ")" + name + R"(", "links": [)";
      for (size_t i = 0; i < links.size(); ++i) {
        const fs::path pass = dir.path() / (links[i]->name + ".pass");
        std::ofstream(pass) << "password\n";
        ::chmod(pass.c_str(), 0600);
        keys += (i ? ", " : "") + std::string(R"({"name": ")") + links[i]->name +
                R"(", "address": ")" + (vias[i].empty() ? links[i]->address() : vias[i]) +
                R"(", "user": "guest", "password_file": ")" + pass.string() + R"(")" +
                (account.empty() ? "" : R"(, "account": ")" + account + R"(")") + "}";
      }
      keys += "], " + extra;
      hub = std::make_unique<HubProcess>(SKROBOT_BIN, dir.path(), account, "", keys, modules);
      for (const auto& [action, patterns] : rules) {
        std::vector<std::string> argv{SKROBOT_BIN, "user", "rule", account, action};
        argv.insert(argv.end(), patterns.begin(), patterns.end());
        argv.insert(argv.end(), {"--users", (dir.path() / "users.json").string()});
        Child rule(argv, {}, dir.path() / "user-rule.log");
        EXPECT_EQ(rule.wait(), 0) << rule.output();
      }
    }
    return hub->start();
  }
  [[nodiscard]] SatelliteOptions options(const std::string& client) const {
    SatelliteOptions o;
    o.connection.address = Address::parse(hub->address()).value();
    o.connection.client_name = client;
    return o;
  }
  std::unique_ptr<SatOnThread> satellite(const std::string& client) {
    auto s = std::make_unique<SatOnThread>(options(client));
    s->start();
    EXPECT_TRUE(eventually([&] { return s->connected(); })) << hub->log();
    return s;
  }
  TempDir dir;
  std::string name;
  std::string extra;           // more top-level keys, each followed by ", "
  std::string modules = "[]";  // the config's "modules" array
  // An account of this hub (in its users file) that each link names as links[].account, with
  // these rules ({"subscribe", {"guest.*"}}, ...).
  std::string account;
  std::vector<std::pair<std::string, std::vector<std::string>>> rules;
  std::vector<NamedHub*> links;
  std::vector<std::string> vias;
  std::unique_ptr<HubProcess> hub;
};

}  // namespace skr::sat::test
