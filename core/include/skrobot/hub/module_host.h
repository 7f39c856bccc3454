// SPDX-License-Identifier: Apache-2.0
// The module host: finds, loads, runs and unloads the hub's modules (shared objects that speak
// the C ABI of plugin-api/include/skrobot/plugin.h).
//
// A bad module never takes the hub down: each failure is logged once (source "core.modules")
// with a stable tag, everything the module registered is removed, and the others go on.
//   MODULE-NOT-FOUND   no file at `path`, or no <name>.so in the search path (lists the dirs)
//   MODULE-LOAD        dlopen failed (dlerror text)
//   MODULE-NO-ENTRY    no skrobot_module_entry symbol
//   MODULE-DESCRIPTOR  null or short descriptor, or no name / init
//   MODULE-ABI         built for another major ABI or a newer minor (both versions named)
//   MODULE-CONFIG      the config object breaks the module's declared keys (ABI 1.2): one line
//                      "<json path>: <reason>" per problem (source "mod.<name>"), then the
//                      failure; the module is never inited
//   MODULE-INIT        init failed (the module's set_error message, or its status)
//   MODULE-START       start failed
//   MODULE-STOP        stop failed (the cleanup goes on)
// Progress lines (info): MODULE-DISABLED, MODULE-LOADED, MODULE-STARTED, MODULE-STOPPED,
// MODULE-UNLOADED (unload: a reload removed it), MODULE-RECONFIGURED (reconfigure, ABI 1.11).
// Lines written by a module carry the source "mod.<name>"; its config problems MODULE-CONFIG.
#pragma once

#include <skrobot/hub/hub_config.h>
#include <skrobot/hub/json_schema.h>
#include <skrobot/runtime/loop.h>
#include <skrobot/runtime/result.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

struct skr_module_ctx;  // the host's per-module record (core/src/module_record.h)

namespace skr {

namespace flow {
class FlowServer;
}

enum class ModuleState { loaded, inited, started, stopped, unloaded };
[[nodiscard]] std::string_view moduleStateName(ModuleState state) noexcept;

// A module the host has loaded (failed ones are in failures() instead).
struct ModuleInfo {
  std::string name;         // as in the config (log source "mod.<name>")
  std::string module_name;  // from the descriptor
  std::string version;
  std::string description;
  std::filesystem::path file;
  ModuleState state = ModuleState::loaded;
  bool own_thread = false;
  std::size_t settings = 0;  // config keys it declares
};

struct ModuleFailure {
  std::string name;
  std::filesystem::path file;  // empty when the file was not found
  std::string tag;             // one of the MODULE-* tags above
  std::string reason;
};

// One key a module declares for its config object (skr_config_key, copied out of the library).
enum class ConfigType { string, integer, number, boolean, array, object, any };
[[nodiscard]] std::string_view configTypeName(ConfigType type) noexcept;

struct ModuleConfigKey {
  std::string key;
  ConfigType type = ConfigType::string;
  bool required = false;
  bool non_empty = false;
  Json::Value default_value;  // null: none
  std::optional<double> min;  // of the value, or of the number of items for arrays
  std::optional<double> max;
  std::vector<std::string> choices;  // strings only; empty: any
  std::string description;
};

// What a module file says about itself.
struct ModuleFileInfo {
  std::filesystem::path file;
  std::string name;
  std::string version;
  std::string description;
  std::uint16_t abi_major = 0;
  std::uint16_t abi_minor = 0;
  std::uint64_t flags = 0;
  // ABI 1.2: the keys of its config object. False: it declares none and gets its config unchecked.
  bool declares_config = false;
  std::vector<ModuleConfigKey> config_keys;
};

// The schema of a module's config object from its declared keys (unknown keys are errors).
[[nodiscard]] schema::Schema moduleConfigSchema(const std::vector<ModuleConfigKey>& keys);

// Checks a config object against a module's declared keys. Problems name the key's path under
// `path` (e.g. "$.modules[2].config.period_ms"); an unknown key is reported at its own path.
// On success `filled` is the config with the declared defaults added. A module that declares
// nothing passes with its config unchanged.
[[nodiscard]] schema::Problems checkModuleConfig(const ModuleFileInfo& info,
                                                 const Json::Value& config, const std::string& path,
                                                 Json::Value& filled);

// The directories searched for <name>.so, in order: `config_paths`, then $SKROBOT_MODULE_PATH
// (colon separated), then <dir of the executable>/../modules (a build tree) and the installed
// modules directory (<prefix>/<libdir>/skrobot/modules, found from the executable's own place).
// Duplicates are dropped; directories need not exist.
[[nodiscard]] std::vector<std::filesystem::path> moduleSearchPath(
    const std::vector<std::filesystem::path>& config_paths);

// Reads a module file's descriptor without initialising it (dlopen runs the library's static
// constructors and calls its entry symbol, nothing else). Fails like the host would load it:
// io_error (dlopen), not_found (no entry symbol), parse_error (bad descriptor), abi_mismatch.
[[nodiscard]] Result<ModuleFileInfo> readModuleDescriptor(const std::filesystem::path& file);

// What loading one config entry would give, found without initialising the module: the same
// steps as ModuleHost::load (resolve the file, dlopen, check the descriptor and the config).
struct ModuleCheck {
  std::string name;            // as in the config (or the file's stem)
  std::string json_path;       // "$.modules[N]"
  bool enabled = true;         // false: nothing else was checked
  std::filesystem::path file;  // empty when not found
  std::string tag;             // empty: it would load; else MODULE-NOT-FOUND, -LOAD, -NO-ENTRY,
                               // -DESCRIPTOR, -ABI or -CONFIG
  std::string reason;          // why, one line (for MODULE-CONFIG: the problems joined by "; ")
  schema::Problems config_problems;  // MODULE-CONFIG only
  ModuleFileInfo info;               // when the descriptor could be read
  [[nodiscard]] bool ok() const noexcept { return tag.empty(); }
};
// Checks every entry in config order. Each enabled module is dlopened and closed again.
[[nodiscard]] std::vector<ModuleCheck> checkModules(
    const std::vector<ModuleEntry>& entries, const std::vector<std::filesystem::path>& search_path);

struct ModuleListing {
  std::filesystem::path file;
  Result<ModuleFileInfo> info;
};
// Every *.so in `search_path` (sorted by name within each directory), with its descriptor.
[[nodiscard]] std::vector<ModuleListing> listModuleFiles(
    const std::vector<std::filesystem::path>& search_path);

// Owns the loaded modules. Not thread-safe: construct it and call every method on the main
// loop's thread (the thread that runs `main_loop`, before, while or after it runs); a call from
// another thread aborts with a line naming the method (Loop::requireLoopThread). Modules on
// their own thread are driven synchronously through Loop::invoke.
class ModuleHost {
 public:
  // `main_loop` must outlive the host. `module_paths` come from HubConfig::module_paths.
  // `server` (may be null) gives modules the FlowNetwork's channels; it must outlive the host.
  ModuleHost(Loop& main_loop, const std::vector<std::filesystem::path>& module_paths,
             flow::FlowServer* server = nullptr);
  ~ModuleHost();  // shutdown()
  ModuleHost(const ModuleHost&) = delete;
  ModuleHost& operator=(const ModuleHost&) = delete;
  ModuleHost(ModuleHost&&) = delete;
  ModuleHost& operator=(ModuleHost&&) = delete;

  // Resolves, dlopens and checks each enabled entry (config order); skips disabled ones.
  void load(const std::vector<ModuleEntry>& entries);
  // Creates the own threads and calls init on every loaded module, in config order.
  void initAll();
  // Calls start on every inited module, in config order.
  void startAll();
  // Calls stop on every started module in the reverse order of start, then removes what each
  // one left registered. Idempotent.
  void stopAll() noexcept;
  // stopAll(), then fini on every inited module (reverse config order), stops their threads and
  // closes the libraries. Idempotent.
  void unloadAll() noexcept;

  // load + initAll + startAll.
  void start(const std::vector<ModuleEntry>& entries);
  // stopAll + unloadAll.
  void shutdown() noexcept { unloadAll(); }
  // A running module reported that it cannot go on (the host call `fail`, ABI 1.10): logged as
  // MODULE-FAILED with `reason`, stopped as at shutdown, its library closed; it moves from
  // modules() to failures(). Nothing when it is not running (any more).
  void failRunning(const std::string& name, const std::string& reason) noexcept;
  // ABI 1.11: gives a running module its changed config in place (`entry.config`, checked
  // against its declared keys first), through its reconfigure step: MODULE-RECONFIGURED.
  // Errc::unsupported when it has no step or declined this change (then restart it),
  // config_error when the config breaks its keys, module_failed when the step failed (its old
  // config stays), not_found when it does not run.
  [[nodiscard]] Result<void> reconfigure(const ModuleEntry& entry);
  // A running module's declared keys (ModuleFileInfo::config_keys) and its config now, with its
  // defaults. not_found when it does not run.
  struct Settings {
    ModuleFileInfo info;
    Json::Value config;
  };
  [[nodiscard]] Result<Settings> settings(const std::string& name) const;
  // Stops one module (if it runs) and unloads it, as at shutdown (a reload that removes or
  // changes it): logged MODULE-STOPPED, MODULE-UNLOADED. False when there is none of that name.
  bool unload(const std::string& name) noexcept;

  [[nodiscard]] std::vector<ModuleInfo> modules() const;
  [[nodiscard]] const std::vector<ModuleFailure>& failures() const noexcept { return failures_; }
  [[nodiscard]] const std::vector<std::filesystem::path>& searchPath() const noexcept {
    return search_path_;
  }
  // Names of the modules in the order they were started (the stop order is the reverse).
  [[nodiscard]] const std::vector<std::string>& startOrder() const noexcept { return started_; }

 private:
  void fail(skr_module_ctx& m, std::string_view tag, const std::string& reason);
  void release(skr_module_ctx& m, bool call_fini) noexcept;
  // Stops a running module (stop, then what it left registered), as stopAll does for each.
  void stopOne(skr_module_ctx& m) noexcept;

  Loop& main_loop_;
  flow::FlowServer* server_;
  std::thread::id control_thread_;
  std::vector<std::filesystem::path> search_path_;
  std::vector<std::unique_ptr<skr_module_ctx>> modules_;  // config order; failed ones removed
  std::vector<skr_module_ctx*> running_;                  // start order
  std::vector<std::string> started_;
  std::vector<ModuleFailure> failures_;
  std::shared_ptr<int> alive_ = std::make_shared<int>(0);  // for work posted by `fail` calls
};

}  // namespace skr
