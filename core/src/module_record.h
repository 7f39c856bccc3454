// SPDX-License-Identifier: Apache-2.0
// The host's record of one module; also the opaque skr_module_ctx handed to it. Internal.
#pragma once

#include "module_calls.h"
#include "module_flow.h"
#include "module_web.h"
#include "shared_library.h"

#include <skrobot/hub/hub_config.h>
#include <skrobot/hub/module_host.h>
#include <skrobot/plugin.h>
#include <skrobot/runtime/loop.h>

#include <atomic>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <utility>
#include <vector>

namespace skr {

// Work a module posted that has not run yet. post() from any thread; runOne() and close() on the
// module's loop thread. Each queued item is paired with exactly one Loop::post of runOne, so
// items run in FIFO order; close() cancels what is left, before the module's code is unloaded.
class PostQueue {
 public:
  // Queues fn and wakes `loop`. False when closed: the caller keeps `user`. `self` is this queue,
  // kept alive by the loop until runOne ran.
  [[nodiscard]] bool post(const std::shared_ptr<PostQueue>& self, Loop& loop, skr_callback fn,
                          skr_callback cancel, void* user);
  void runOne();
  void close() noexcept;

 private:
  struct Item {
    skr_callback fn;
    skr_callback cancel;
    void* user;
  };
  std::mutex mutex_;
  bool open_ = true;
  std::deque<Item> items_;
};

// The host's table of services (host_api.cpp).
[[nodiscard]] const skr_host_api* hostApi() noexcept;
[[nodiscard]] const char* statusText(skr_status status) noexcept;
// The one mapping from an Errc (a flow or local failure) to the C seam's status: not_found and
// owner_gone -> SKR_ERR_NOT_FOUND; invalid_argument, parse_error, already_exists and
// permission_denied -> SKR_ERR_INVALID_ARGUMENT; every other failure -> SKR_ERR_FAILED.
[[nodiscard]] skr_status toStatus(Errc code) noexcept;

// Checks a descriptor the way the host loads it (module_files.cpp). The library stays open.
struct OpenedModule {
  SharedLibrary library;
  const skr_module_descriptor* descriptor = nullptr;
  ModuleFileInfo info;
};
[[nodiscard]] Result<OpenedModule> openModule(const std::filesystem::path& file);
// Copies and checks a module's declared config keys (module_config.cpp): a bad declaration (no
// name, twice the same key, unknown type, a default that is not JSON or breaks its own rules)
// is Errc::parse_error, which refuses the module like any other descriptor defect.
[[nodiscard]] Result<std::vector<ModuleConfigKey>> readConfigKeys(const skr_config_key* keys,
                                                                  std::size_t count);
// One entry through every check of ModuleHost::load (checkModules runs it for each entry). When
// it passes, `opened_out` gets the open library and `config_out` the config with the declared
// defaults (either may be null).
[[nodiscard]] ModuleCheck prepareModule(const ModuleEntry& entry, const std::string& json_path,
                                        const std::vector<std::filesystem::path>& search_path,
                                        OpenedModule* opened_out, Json::Value* config_out);
// The file for an entry: its `path`, or <dir>/<name>.so in `search_path`. Errc::not_found says
// where it looked.
[[nodiscard]] Result<std::filesystem::path> resolveModule(
    const ModuleEntry& entry, const std::vector<std::filesystem::path>& search_path);

}  // namespace skr

struct skr_module_ctx {
  skr::ModuleEntry entry;
  std::string name;        // entry.name, or the file's stem
  std::string log_source;  // "mod.<name>"
  std::string json_path;   // "$.modules[N]"
  std::string config_json;
  std::filesystem::path file;

  skr::SharedLibrary library;
  skr_module_descriptor descriptor{};  // copy of the 1.0 fields (the rest zero); into `library`
  skr::ModuleFileInfo info;            // strings copied out of the library
  skr::ModuleState state = skr::ModuleState::loaded;
  void* instance = nullptr;

  bool own_thread = false;
  std::unique_ptr<skr::LoopThread> thread;  // when own_thread; stopped after fini
  // When own_thread: its channel and database calls, run on the main loop (ABI 1.10).
  std::shared_ptr<skr::ModuleCalls> calls;
  skr::Loop* loop = nullptr;       // the module's loop: main or thread->loop()
  std::thread::id control_thread;  // runs the main loop (see ModuleHost)
  std::string loop_name;
  skr_loop_info loop_info{};

  // Loop thread only.
  bool accepting = false;  // registrations allowed: from init until stop returned
  bool ticking = false;    // ticks delivered: from start until stop
  std::vector<std::pair<skr_tick_handle, skr::TickId>> ticks;
  std::shared_ptr<skr::PostQueue> posts = std::make_shared<skr::PostQueue>();
  skr::flow::FlowServer* server = nullptr;     // the hub's, for channel calls (ABI 1.1)
  std::unique_ptr<skr::ModuleFlow> flow;       // created by the first channel call
  std::unique_ptr<skr::ModuleWebSockets> web;  // created by the first ws_serve (ABI 1.8)
  // What it may do: its config entry's account's rules, else the defaults (null).
  std::shared_ptr<const skr::flow::AccessRules> access;

  // The host call `fail` (ABI 1.10, any thread): the first one posts the module's failure to
  // the main loop through on_fail (ModuleHost::failRunning); later ones are ignored.
  std::atomic<bool> failed{false};
  std::function<void(std::string)> on_fail;

  std::mutex error_mutex;  // set_error / config_error may come from any thread
  std::string error;       // set_error during the current step
  std::string config_error;

  // True on the module's loop thread; for the main loop also before it first ran.
  [[nodiscard]] bool onLoopThread() const noexcept {
    return loop != nullptr &&
           (loop->isLoopThread() || (!own_thread && std::this_thread::get_id() == control_thread));
  }
  // Removes what the module left registered and cancels its pending work. Loop thread.
  void removeRegistrations() noexcept {
    accepting = false;
    ticking = false;
    for (const auto& t : ticks) loop->removeTickHandler(t.second);
    ticks.clear();
    posts->close();
    web.reset();  // its web endpoints and their connections go
    // Its channels and subscriptions go, and everyone is told (on the main loop, where they live).
    if (own_thread && calls && flow && onLoopThread()) {
      (void)calls->call([this] {
        flow.reset();
        return SKR_OK;
      });
    }
    flow.reset();
  }
  void clearError() {
    std::lock_guard lock(error_mutex);
    error.clear();
  }
  [[nodiscard]] std::string takeError() {
    std::lock_guard lock(error_mutex);
    std::string e = std::move(error);
    error.clear();
    return e;
  }
};
