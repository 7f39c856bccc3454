// SPDX-License-Identifier: Apache-2.0
#include <skrobot/hub/module_host.h>

#include "module_record.h"

#include <skrobot/runtime/log.h>

#include <skrobot/support/json.hpp>

#include <algorithm>
#include <cstddef>
#include <cstring>

#include <cstdio>
#include <cstdlib>
#include <functional>
#include <string>
#include <thread>
#include <utility>

namespace skr {
namespace {

constexpr std::string_view kSource = "core.modules";

// The host's contract: every method on the main loop's thread, which is also the thread that
// constructed the host. A call from elsewhere aborts with a line naming it, in every build.
void requireHostThread(const Loop& main_loop, std::thread::id control, const char* what) noexcept {
  main_loop.requireLoopThread(what);
  if (std::this_thread::get_id() == control || main_loop.isLoopThread()) return;
  std::fprintf(stderr, "skrobot: %s called off the thread that created the module host\n", what);
  std::abort();
}

// Runs `fn` on the module's loop thread and waits for it, running the channel calls it makes
// meanwhile (module_calls.h).
template <typename F>
void onModuleThread(skr_module_ctx& m, F&& fn) {
  if (m.own_thread && m.thread) {
    m.calls->runStep(m.thread->loop(), std::function<void()>(std::forward<F>(fn)));
  } else {
    fn();
  }
}

std::string describe(const skr_module_ctx& m) {
  return "module " + m.name + (m.file.empty() ? "" : " (" + m.file.string() + ")");
}

// Why a step failed: the module's message, else its config problem, else its status.
std::string stepFailure(skr_module_ctx& m, skr_status status) {
  std::string why = m.takeError();
  if (why.empty()) {
    std::lock_guard lock(m.error_mutex);
    if (!m.config_error.empty()) why = "config error: " + m.config_error;
  }
  const std::string code =
      "status " + std::to_string(static_cast<int>(status)) + " (" + statusText(status) + ")";
  return why.empty() ? "returned " + code : why + " [" + code + "]";
}

}  // namespace

ModuleHost::ModuleHost(Loop& main_loop, const std::vector<std::filesystem::path>& module_paths,
                       flow::FlowServer* server)
    : main_loop_(main_loop),
      server_(server),
      control_thread_(std::this_thread::get_id()),
      search_path_(moduleSearchPath(module_paths)) {}

ModuleHost::~ModuleHost() {
  shutdown();
}

void ModuleHost::fail(skr_module_ctx& m, std::string_view tag, const std::string& reason) {
  log::error(kSource, tag, describe(m) + ": " + reason);
  failures_.push_back(ModuleFailure{m.name, m.file, std::string(tag), reason});
}

void ModuleHost::load(const std::vector<ModuleEntry>& entries) {
  requireHostThread(main_loop_, control_thread_, "ModuleHost::load");
  for (std::size_t i = 0; i < entries.size(); ++i) {
    auto m = std::make_unique<skr_module_ctx>();
    m->entry = entries[i];
    m->name = !m->entry.name.empty() ? m->entry.name : m->entry.path.stem().string();
    m->entry.name = m->name;
    m->log_source = "mod." + m->name;
    m->server = server_;
    m->json_path =
        !m->entry.json_path.empty() ? m->entry.json_path : "$.modules[" + std::to_string(i) + "]";
    if (!m->entry.enabled) {
      log::info(kSource, "MODULE-DISABLED", describe(*m) + " is disabled in the config");
      continue;
    }
    OpenedModule opened;
    Json::Value config;
    const ModuleCheck check = prepareModule(m->entry, m->json_path, search_path_, &opened, &config);
    m->file = check.file;
    if (!check.ok()) {
      // Each config problem on its own line, where the module's own MODULE-CONFIG lines go.
      for (const auto& p : check.config_problems) {
        log::error(m->log_source, "MODULE-CONFIG", p.path + ": " + p.reason);
      }
      fail(*m, check.tag, check.reason);
      continue;
    }
    m->library = std::move(opened.library);
    // Only the 1.0 fields: a 1.1 module's descriptor ends there (the rest stays zero).
    std::memcpy(&m->descriptor, opened.descriptor, offsetof(skr_module_descriptor, config_keys));
    m->descriptor.struct_size = sizeof(skr_module_descriptor);
    // ABI 1.11: its reconfigure step, when its descriptor is that long.
    if (opened.descriptor->struct_size >=
        offsetof(skr_module_descriptor, reconfigure) + sizeof(m->descriptor.reconfigure)) {
      m->descriptor.reconfigure = opened.descriptor->reconfigure;
    }
    m->info = std::move(opened.info);
    m->entry.config = std::move(config);  // with the declared defaults
    m->own_thread = m->entry.own_thread || (m->info.flags & SKR_MODULE_WANTS_OWN_THREAD) != 0;
    m->control_thread = control_thread_;
    m->on_fail = [this, alive = std::weak_ptr<int>(alive_), name = m->name](std::string reason) {
      main_loop_.post([this, alive, name, reason = std::move(reason)] {
        if (alive.lock()) failRunning(name, reason);
      });
    };
    m->config_json = support::writeJson(m->entry.config);
    log::info(kSource, "MODULE-LOADED",
              describe(*m) + ": " + m->info.name + " " + m->info.version +
                  (m->own_thread ? " on its own thread" : ""));
    modules_.push_back(std::move(m));
  }
}

void ModuleHost::initAll() {
  requireHostThread(main_loop_, control_thread_, "ModuleHost::initAll");
  for (auto it = modules_.begin(); it != modules_.end();) {
    skr_module_ctx& m = **it;
    if (m.state != ModuleState::loaded) {
      ++it;
      continue;
    }
    if (!m.entry.account.empty()) {
      m.access = server_ != nullptr ? server_->accountAccess(m.entry.account) : nullptr;
      if (!m.access) {
        fail(m, "MODULE-ACCOUNT",
             "its config names the account \"" + m.entry.account +
                 "\", which the users file does not have (skrobot user add " + m.entry.account +
                 ")");
        release(m, false);
        it = modules_.erase(it);
        continue;
      }
    }
    if (m.own_thread) {
      LoopOptions options = m.entry.loop;
      if (options.name.empty() || options.name == main_loop_.name()) options.name = m.log_source;
      try {
        m.thread = std::make_unique<LoopThread>(std::move(options));
        m.thread->start();
      } catch (const std::exception& e) {  // std::system_error: no thread for it
        fail(m, "MODULE-INIT", std::string("cannot start its loop thread: ") + e.what());
        m.thread.reset();  // never ran: nothing to invoke on it
        release(m, false);
        it = modules_.erase(it);
        continue;
      }
      m.loop = &m.thread->loop();
      m.calls = std::make_shared<ModuleCalls>(main_loop_);
    } else {
      m.loop = &main_loop_;
    }
    const LoopOptions& lo = m.loop->options();
    m.loop_name = lo.name;
    m.loop_info =
        skr_loop_info{sizeof(skr_loop_info), m.own_thread ? 1u : 0u,        lo.fast_interval_ns,
                      lo.slow_interval_ns,   static_cast<int32_t>(lo.mode), 0,
                      m.loop_name.c_str()};
    skr_status status = SKR_OK;
    onModuleThread(m, [&m, &status] {
      m.accepting = true;
      void* instance = nullptr;
      status = m.descriptor.init(hostApi(), &m, &instance);
      if (status == SKR_OK) {
        m.instance = instance;
      } else {
        m.removeRegistrations();
      }
    });
    if (status != SKR_OK) {
      fail(m, "MODULE-INIT", "init failed: " + stepFailure(m, status));
      release(m, false);
      it = modules_.erase(it);
      continue;
    }
    m.state = ModuleState::inited;
    ++it;
  }
}

void ModuleHost::startAll() {
  requireHostThread(main_loop_, control_thread_, "ModuleHost::startAll");
  for (auto it = modules_.begin(); it != modules_.end();) {
    skr_module_ctx& m = **it;
    if (m.state != ModuleState::inited) {
      ++it;
      continue;
    }
    skr_status status = SKR_OK;
    onModuleThread(m, [&m, &status] {
      m.clearError();
      // Ticks flow from here: handlers the module adds in start run from the next tick.
      if (m.descriptor.start != nullptr) status = m.descriptor.start(m.instance);
      if (status == SKR_OK) {
        m.ticking = true;
      } else {
        m.removeRegistrations();
      }
    });
    if (status != SKR_OK) {
      fail(m, "MODULE-START", "start failed: " + stepFailure(m, status));
      release(m, true);
      it = modules_.erase(it);
      continue;
    }
    m.state = ModuleState::started;
    running_.push_back(&m);
    started_.push_back(m.name);
    log::info(kSource, "MODULE-STARTED", describe(m));
    ++it;
  }
}

void ModuleHost::stopAll() noexcept {
  requireHostThread(main_loop_, control_thread_, "ModuleHost::stopAll");
  while (!running_.empty()) {
    skr_module_ctx& m = *running_.back();
    running_.pop_back();
    stopOne(m);
  }
}

void ModuleHost::stopOne(skr_module_ctx& m) noexcept {
  skr_status status = SKR_OK;
  try {
    onModuleThread(m, [&m, &status] {
      m.ticking = false;
      m.clearError();
      if (m.descriptor.stop != nullptr) status = m.descriptor.stop(m.instance);
      m.removeRegistrations();  // whatever it forgot, and work it posted that did not run
    });
    if (status != SKR_OK) fail(m, "MODULE-STOP", "stop failed: " + stepFailure(m, status));
    log::info(kSource, "MODULE-STOPPED", describe(m));
  } catch (...) {  // out of memory while logging: the module is stopped all the same
  }
  m.state = ModuleState::stopped;
}

Result<void> ModuleHost::reconfigure(const ModuleEntry& entry) {
  requireHostThread(main_loop_, control_thread_, "ModuleHost::reconfigure");
  auto r = std::find_if(running_.begin(), running_.end(),
                        [&entry](const skr_module_ctx* m) { return m->name == entry.name; });
  if (r == running_.end()) return makeError(Errc::not_found, "no module " + entry.name + " runs");
  skr_module_ctx& m = **r;
  if (m.descriptor.reconfigure == nullptr) {
    return makeError(Errc::unsupported, entry.name + " has no reconfigure step");
  }
  Json::Value filled;
  const schema::Problems problems =
      checkModuleConfig(m.info, entry.config, m.json_path + ".config", filled);
  if (!problems.empty()) {
    std::string text;
    for (const auto& p : problems) text += (text.empty() ? "" : "; ") + p.path + ": " + p.reason;
    return makeError(Errc::config_error, text);
  }
  skr_status status = SKR_OK;
  onModuleThread(m, [&m, &filled, &status] {
    // The old config lives until the step returned: strings read from it stay valid until then.
    Json::Value old = std::exchange(m.entry.config, std::move(filled));
    std::string old_json = std::exchange(m.config_json, support::writeJson(m.entry.config));
    m.clearError();
    status = m.descriptor.reconfigure(m.instance);
    if (status != SKR_OK) {
      m.entry.config = std::move(old);
      m.config_json = std::move(old_json);
    }
  });
  if (status != SKR_OK) {
    const std::string why = stepFailure(m, status);
    return makeError(status == SKR_ERR_UNSUPPORTED ? Errc::unsupported : Errc::module_failed,
                     entry.name + " did not take the change: " + why);
  }
  log::info(kSource, "MODULE-RECONFIGURED", describe(m) + ": " + m.config_json);
  return {};
}

Result<ModuleHost::Settings> ModuleHost::settings(const std::string& name) const {
  for (const skr_module_ctx* m : running_) {
    if (m->name == name) return Settings{m->info, m->entry.config};
  }
  return makeError(Errc::not_found, "no module " + name + " runs");
}

bool ModuleHost::unload(const std::string& name) noexcept {
  requireHostThread(main_loop_, control_thread_, "ModuleHost::unload");
  auto it = std::find_if(modules_.begin(), modules_.end(),
                         [&name](const auto& m) { return m->name == name; });
  if (it == modules_.end()) return false;
  skr_module_ctx& m = **it;
  if (auto r = std::find(running_.begin(), running_.end(), &m); r != running_.end()) {
    running_.erase(r);
    stopOne(m);
  }
  if (m.state != ModuleState::unloaded) release(m, m.state != ModuleState::loaded);
  std::erase(started_, name);
  try {
    log::info(kSource, "MODULE-UNLOADED", describe(m));
  } catch (...) {
  }
  modules_.erase(it);
  return true;
}

void ModuleHost::failRunning(const std::string& name, const std::string& reason) noexcept {
  requireHostThread(main_loop_, control_thread_, "ModuleHost::failRunning");
  auto r = std::find_if(running_.begin(), running_.end(),
                        [&name](const skr_module_ctx* m) { return m->name == name; });
  if (r == running_.end()) return;
  skr_module_ctx& m = **r;
  running_.erase(r);
  try {
    fail(m, "MODULE-FAILED", reason);
    onModuleThread(m, [&m] {
      m.ticking = false;
      m.clearError();
      if (m.descriptor.stop != nullptr) (void)m.descriptor.stop(m.instance);
      m.removeRegistrations();
    });
    log::info(kSource, "MODULE-STOPPED", describe(m));
  } catch (...) {  // out of memory while logging: the module is stopped all the same
  }
  release(m, true);
  std::erase_if(modules_, [&m](const std::unique_ptr<skr_module_ctx>& p) { return p.get() == &m; });
}

void ModuleHost::release(skr_module_ctx& m, bool call_fini) noexcept {
  try {
    onModuleThread(m, [&m, call_fini] {
      m.removeRegistrations();
      if (call_fini && m.descriptor.fini != nullptr) m.descriptor.fini(m.instance);
      m.instance = nullptr;
    });
  } catch (...) {
  }
  if (m.thread) m.thread->stop();  // after fini: the module's code ran on it until now
  m.thread.reset();
  m.library.close();
  m.state = ModuleState::unloaded;
}

void ModuleHost::unloadAll() noexcept {
  requireHostThread(main_loop_, control_thread_, "ModuleHost::unloadAll");
  stopAll();
  for (auto it = modules_.rbegin(); it != modules_.rend(); ++it) {
    skr_module_ctx& m = **it;
    if (m.state == ModuleState::unloaded) continue;
    release(m, m.state != ModuleState::loaded);
  }
}

void ModuleHost::start(const std::vector<ModuleEntry>& entries) {
  load(entries);
  initAll();
  startAll();
}

std::vector<ModuleInfo> ModuleHost::modules() const {
  std::vector<ModuleInfo> out;
  out.reserve(modules_.size());
  for (const auto& m : modules_) {
    out.push_back(ModuleInfo{m->name, m->info.name, m->info.version, m->info.description, m->file,
                             m->state, m->own_thread, m->info.config_keys.size()});
  }
  return out;
}

}  // namespace skr
