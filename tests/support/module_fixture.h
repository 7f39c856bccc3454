// SPDX-License-Identifier: Apache-2.0
// A hub with its FlowServer and a ModuleHost on a loop thread, for tests of real modules
// (build/<preset>/modules/<name>.so): load them with their config objects, then talk to their
// channels from TestClients over the hub's socket.
//
//   startHub();
//   startModule("face-detect", R"({"input":"guest.camera"})");
//   TestClient sat = flowClient();
#pragma once

#include "flow_fixture.h"

#include <skrobot/hub/module_host.h>

#include <json/json.h>

#include <filesystem>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

namespace skr::test {

class ModuleFixture : public FlowFixture {
 protected:
  // Path of a module built by this tree (SKROBOT_MODULE_DIR).
  static std::filesystem::path modulePath(const std::string& name) {
    return std::filesystem::path(SKROBOT_MODULE_DIR) / (name + ".so");
  }

  // Loads, inits and starts modules on the hub's loop. Returns the failures, empty when all
  // started (each failure names the module and why).
  std::vector<std::string> startModules(std::vector<ModuleEntry> entries) {
    std::vector<std::string> failures;
    onHub([&] {
      if (!host_) {
        host_ = std::make_unique<ModuleHost>(hub_->loop(), std::vector<std::filesystem::path>{},
                                             server_.get());
      }
      const std::size_t before = host_->failures().size();
      host_->start(entries);
      const auto& all = host_->failures();
      for (std::size_t i = before; i < all.size(); ++i) {
        failures.push_back(all[i].name + " [" + all[i].tag + "]: " + all[i].reason);
      }
    });
    return failures;
  }

  // One module of this tree, named `name` in the config, with its config object as JSON text.
  // `own_thread` runs it on a loop thread of its own; `file` is another module of this tree, or a
  // path (containing '/') to any .so.
  std::vector<std::string> startModule(const std::string& name,
                                       const std::string& config_json = "{}",
                                       bool own_thread = false, const std::string& file = {}) {
    ModuleEntry e;
    e.name = name;
    e.path = file.find('/') != std::string::npos ? std::filesystem::path(file)
                                                 : modulePath(file.empty() ? name : file);
    e.own_thread = own_thread;
    Json::CharReaderBuilder builder;
    std::string errors;
    std::istringstream in(config_json);
    EXPECT_TRUE(Json::parseFromStream(builder, in, &e.config, &errors)) << errors;
    e.json_path = "$.modules[" + std::to_string(next_index_++) + "]";
    return startModules({e});
  }

  void stopModules() {
    if (hub_ && host_) onHub([&] { host_.reset(); });
  }
  void TearDown() override {
    stopModules();
    FlowFixture::TearDown();
  }

  std::unique_ptr<ModuleHost> host_;
  int next_index_ = 0;
};

}  // namespace skr::test
