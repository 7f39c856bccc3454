// SPDX-License-Identifier: Apache-2.0
// What reloading the config changes (flowctl reload, SIGHUP; docs/robot.md): the difference
// between the config the hub runs and the one read again, as the hub applies it. A pure function
// of the two configs.
#pragma once

#include <skrobot/hub/hub_config.h>
#include <skrobot/runtime/flow/variant.h>
#include <skrobot/runtime/loop.h>
#include <skrobot/runtime/result.h>

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

namespace skr {

namespace flow {
class FlowServer;
}
class ModuleHost;
class Supervisor;

struct ReloadPlan {
  // Enabled modules by name: loaded, stopped and unloaded, or both (their entry changed).
  std::vector<ModuleEntry> load;       // new ones and changed ones (the new entry)
  std::vector<std::string> unload;     // removed or disabled ones, and changed ones
  std::vector<std::string> restarted;  // the changed ones (in both lists above)
  // Changed in their `config` alone: given it in place (ABI 1.11 reconfigure), else restarted.
  std::vector<ModuleEntry> reconfigure;
  // Satellites by name.
  std::vector<SatelliteEntry> satellites_added;
  std::vector<std::string> satellites_removed;
  std::vector<SatelliteEntry> satellites_changed;  // the new entry
  bool log_level = false;                          // log.level changed
  // Top-level keys that changed and take a restart of the hub to apply ("$.server", ...).
  std::vector<std::string> not_applied;
  [[nodiscard]] bool empty() const noexcept {
    return load.empty() && unload.empty() && reconfigure.empty() && satellites_added.empty() &&
           satellites_removed.empty() && satellites_changed.empty() && !log_level;
  }
};

// `now` is the config the hub runs, `next` the one read again (both loaded by loadHubConfig).
[[nodiscard]] ReloadPlan planReload(const HubConfig& now, const HubConfig& next);

// One line per change, for the log and flowctl reload ("module added: foo", ...).
[[nodiscard]] std::vector<std::string> describe(const ReloadPlan& plan);

// Reloads the hub's config file on request (SIGHUP, ADMIN reload: flowctl reload), and loads or
// unloads one module on request (ADMIN module_load, module_unload: flowctl module). The file is
// read and checked (the hub's schema, and each module to load: its file, descriptor and declared
// keys) on a thread of its own; a config with any problem changes nothing and is reported, with
// its JSON paths, as at start (HUB-RELOAD-REFUSED). Else the plan is applied on the loop thread:
// satellites, then modules (those that go are stopped and unloaded first; those that failed
// before are tried again), then the log level; what takes a restart is said (HUB-RELOAD lines).
// Main loop thread only.
class Reloader {
 public:
  using Done = std::function<void(Result<std::vector<std::string>>)>;
  // Registers ADMIN "reload". `fixed_level`: the command line's --log-level, which a reload
  // keeps.
  Reloader(Loop& loop, flow::FlowServer& server, ModuleHost& modules, Supervisor& satellites,
           HubConfig current, std::optional<log::Level> fixed_level);
  ~Reloader();  // waits for a reading thread
  Reloader(const Reloader&) = delete;
  Reloader& operator=(const Reloader&) = delete;

  // `done` (loop thread) gets the changes made, or why none was: Errc::config_error (the file's
  // problems), not_found or io_error (it cannot be read), module_failed (a module to load would
  // fail), limit_exceeded (a reload is under way).
  void reload(Done done);
  // ADMIN module_load (flowctl module load): the module `name` (a plain name, found on the
  // module search path only: a new .so dropped into a directory of module_paths), with `config`
  // checked against its declared keys, checked off the loop, then started; `done` gets its
  // file. It is not written into the config: a restart of the hub forgets it. ADMIN
  // module_unload: a running module stopped and unloaded (config's or not).
  using ModuleDone = std::function<void(Result<std::string>)>;
  void loadModule(const std::string& name, Json::Value config, ModuleDone done);
  // ADMIN module_config (flowctl module config): without `set` (null), a running module's
  // declared keys (key, type, required, default, min, max, choices, description) with their
  // values now; with it (an object of keys and values), the module's config changed at run time:
  // checked against its keys, given in place (reconfigure) or by a restart, and with `save`
  // written into the config file (only those values: config_edit.h). Unsaved, the next reload
  // or restart goes back to the file's. `done` gets {"module", "keys"} or {"module", "applied":
  // "reconfigured" | "restarted", "saved": file}.
  using ConfigDone = std::function<void(Result<flow::Variant>)>;
  void moduleConfig(const std::string& name, const flow::Variant& set, bool save, ConfigDone done);
  // hub.stats's "modules" (the network page's table): each running module's name, version,
  // description, state, file and number of declared settings, then each failed one's name,
  // file and reason (state "failed").
  [[nodiscard]] flow::Variant modules() const;

 private:
  void apply(HubConfig next, Done done);
  // `work` on the reading thread; what it returns runs on the loop (if this still exists).
  void offLoop(std::function<std::function<void()>()> work);

  Loop& loop_;
  flow::FlowServer& server_;
  ModuleHost& modules_;
  Supervisor& satellites_;
  HubConfig current_;
  std::optional<log::Level> fixed_level_;
  std::thread reader_;
  bool busy_ = false;
  std::shared_ptr<int> alive_ = std::make_shared<int>(0);
};

}  // namespace skr
