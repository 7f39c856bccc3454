// SPDX-License-Identifier: Apache-2.0
// Test helper: a real hub with supervised satellites (docs/robot.md) and an administrator, driven
// with flowctl as an operator would. Needs SKROBOT_BIN and FLOWCTL_BIN (tests/CMakeLists.txt).
#pragma once

#include "hub_process.h"

#include <skrobot/runtime/flow/variant.h>

#include <string>
#include <vector>

namespace skr::sat::test {

constexpr const char* kAdmin = "ops";  // HubProcess's users-file account, made an administrator

// A hub whose config has `satellites` (a JSON array) and `modules`, with the administrator
// "ops" (password s3cret-pass) in its users file.
struct SupervisedHub {
  explicit SupervisedHub(const std::string& satellites, const std::string& modules = "[]")
      : hub(SKROBOT_BIN, dir.path(), kAdmin, "", R"("satellites": )" + satellites + ", ", modules) {
    Child role({SKROBOT_BIN, "user", "role", kAdmin, "admin", "--users",
                (dir.path() / "users.json").string()},
               {}, dir.path() / "role.log");
    role.wait();
  }
  // flowctl as the administrator; its output, and its exit code in `code`.
  std::string flowctl(const std::vector<std::string>& args, int* code = nullptr,
                      const std::string& user = kAdmin) {
    std::vector<std::string> argv{FLOWCTL_BIN};
    argv.insert(argv.end(), args.begin(), args.end());
    const fs::path out = dir.path() / ("flowctl-" + std::to_string(++runs) + ".out");
    Child c(argv,
            {"ROBOT_ADDRESS=" + hub.address(), "ROBOT_USER=" + user,
             "ROBOT_PASSWORD=" + std::string(user == kAdmin ? "s3cret-pass" : "password")},
            out);
    const int rc = c.wait(20000);
    if (code != nullptr) *code = rc;
    return c.output();
  }
  // The satellite `name` of `flowctl --json ps`.
  skr::flow::Variant ps(const std::string& name) {
    auto v = skr::flow::variantFromJsonText(flowctl({"--json", "ps"}));
    if (!v || v->asList() == nullptr) return {};
    for (const auto& s : *v->asList()) {
      if (s.asMap() != nullptr && s.asMap()->at("name").asString() != nullptr &&
          *s.asMap()->at("name").asString() == name) {
        return s;
      }
    }
    return {};
  }
  static std::string text(const skr::flow::Variant& sat, const char* key) {
    if (sat.asMap() == nullptr || sat.asMap()->count(key) == 0) return {};
    const skr::flow::Variant& v = sat.asMap()->at(key);
    return v.asString() != nullptr ? *v.asString() : skr::flow::variantToJsonText(v);
  }
  [[nodiscard]] size_t count(const std::string& text) const {
    const std::string log = hub.log();
    size_t n = 0;
    for (size_t at = log.find(text); at != std::string::npos; at = log.find(text, at + 1)) ++n;
    return n;
  }

  TempDir dir;
  HubProcess hub;
  int runs = 0;
};

}  // namespace skr::sat::test
