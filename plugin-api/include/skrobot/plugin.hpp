// SPDX-License-Identifier: Apache-2.0
// Header-only C++ helper over the C ABI in plugin.h. It lives entirely inside the module: the
// classes below never cross the seam, and every exception is caught before it could.
//
//   class Hello final : public skr::plugin::Module {
//    public:
//     explicit Hello(skr::plugin::Host& host) : host_(host) {}   // init; may throw
//     void start() override { tick_ = host_.onTick(skr::plugin::Tick::one_sec, [this] {
//       host_.log.info("HELLO", "one more second"); }); }
//     void stop() override { tick_.reset(); }
//    private:
//     skr::plugin::Host& host_;
//     skr::plugin::TickHandle tick_;
//   };
//   SKR_MODULE(Hello, "hello", "1.0.0", "says hello every second", 0)
#pragma once

#include <skrobot/plugin.h>

#include <cstdint>
#include <functional>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>

namespace skr::plugin {

enum class Tick { fast = SKR_TICK_FAST, slow = SKR_TICK_SLOW, one_sec = SKR_TICK_ONE_SEC };

// Throw from the constructor, start() or stop() to fail that step with a chosen status.
// Any other exception fails it with SKR_ERR_EXCEPTION and its what() as the message.
class Failure : public std::runtime_error {
 public:
  Failure(skr_status status, const std::string& message)
      : std::runtime_error(message), status_(status) {}
  [[nodiscard]] skr_status status() const noexcept { return status_; }

 private:
  skr_status status_;
};

// Log lines with source "mod.<name>". The parts are streamed together:
//   host.log.info("EXAMPLE-TICK", "tick ", n, " after ", ms, " ms");
// Any thread. Never throws.
class Log {
 public:
  Log(const skr_host_api* api, skr_module_ctx* ctx) noexcept : api_(api), ctx_(ctx) {}

  template <typename... Parts>
  void debug(std::string_view tag, const Parts&... parts) const noexcept {
    write(SKR_LOG_DEBUG, tag, parts...);
  }
  template <typename... Parts>
  void info(std::string_view tag, const Parts&... parts) const noexcept {
    write(SKR_LOG_INFO, tag, parts...);
  }
  template <typename... Parts>
  void warn(std::string_view tag, const Parts&... parts) const noexcept {
    write(SKR_LOG_WARN, tag, parts...);
  }
  template <typename... Parts>
  void error(std::string_view tag, const Parts&... parts) const noexcept {
    write(SKR_LOG_ERROR, tag, parts...);
  }

  template <typename... Parts>
  void write(skr_log_level level, std::string_view tag, const Parts&... parts) const noexcept {
    try {
      if (api_->log_enabled(ctx_, level) == 0) return;
      std::ostringstream text;
      ((text << parts), ...);
      api_->log(ctx_, level, std::string(tag).c_str(), text.str().c_str());
    } catch (...) {  // out of memory while formatting: drop the line
    }
  }

 private:
  const skr_host_api* api_;
  skr_module_ctx* ctx_;
};

// A tick registration; removes it when destroyed or reset. Movable, not copyable.
// Destroy it on the module's loop thread (in stop(), or with the module).
class TickHandle {
 public:
  TickHandle() noexcept = default;
  TickHandle(const TickHandle&) = delete;
  TickHandle& operator=(const TickHandle&) = delete;
  TickHandle(TickHandle&& other) noexcept { swap(other); }
  TickHandle& operator=(TickHandle&& other) noexcept {
    TickHandle(std::move(other)).swap(*this);
    return *this;
  }
  ~TickHandle() { reset(); }

  void reset() noexcept {
    // The host may have removed it already (after stop): SKR_ERR_NOT_FOUND is fine then.
    if (handle_ != 0) bound_->api->tick_remove(bound_->ctx, handle_);
    handle_ = 0;
    bound_.reset();
  }
  [[nodiscard]] bool active() const noexcept { return handle_ != 0; }

 private:
  friend class Host;
  struct Bound {
    const skr_host_api* api;
    skr_module_ctx* ctx;
    std::function<void()> fn;
  };
  void swap(TickHandle& other) noexcept {
    std::swap(handle_, other.handle_);
    std::swap(bound_, other.bound_);
  }

  skr_tick_handle handle_ = 0;
  // Heap-allocated so that its address (the C `user` pointer) survives moves of the handle.
  std::unique_ptr<Bound> bound_;
};

namespace detail {

// Runs module code called from C; an escaping exception would be undefined behaviour there.
template <typename F>
skr_status guarded(const skr_host_api* api, skr_module_ctx* ctx, const char* step,
                   F&& fn) noexcept {
  try {
    fn();
    return SKR_OK;
  } catch (const Failure& e) {
    api->set_error(ctx, e.what());
    return e.status() == SKR_OK ? SKR_ERR_FAILED : e.status();
  } catch (const std::exception& e) {
    api->set_error(ctx, (std::string(step) + " threw: " + e.what()).c_str());
    return SKR_ERR_EXCEPTION;
  } catch (...) {
    api->set_error(ctx, (std::string(step) + " threw an unknown exception").c_str());
    return SKR_ERR_EXCEPTION;
  }
}

// Callback-side guard: no caller to report to, so the exception becomes a log line.
template <typename F>
void logged(const skr_host_api* api, skr_module_ctx* ctx, const char* what, F&& fn) noexcept {
  try {
    fn();
  } catch (const std::exception& e) {
    Log(api, ctx).error("MODULE-EXCEPTION", what, " threw: ", e.what());
  } catch (...) {
    Log(api, ctx).error("MODULE-EXCEPTION", what, " threw an unknown exception");
  }
}

}  // namespace detail

// The module's view of the hub: a copyable pair (api, ctx), valid until the module is destroyed.
class Host {
 public:
  Host(const skr_host_api* api, skr_module_ctx* ctx) noexcept
      : log(api, ctx), api_(api), ctx_(ctx) {}

  Log log;

  // --- config (any thread): a missing key gives the default, a wrong type logs MODULE-CONFIG.
  [[nodiscard]] std::string configString(const char* key, const std::string& def = {}) const {
    return api_->config_string(ctx_, key, def.c_str());
  }
  [[nodiscard]] std::int64_t configInt(const char* key, std::int64_t def = 0) const noexcept {
    return api_->config_int(ctx_, key, def);
  }
  [[nodiscard]] double configDouble(const char* key, double def = 0) const noexcept {
    return api_->config_double(ctx_, key, def);
  }
  [[nodiscard]] bool configBool(const char* key, bool def = false) const noexcept {
    return api_->config_bool(ctx_, key, def ? 1 : 0) != 0;
  }
  [[nodiscard]] bool configHas(const char* key) const noexcept {
    return api_->config_has(ctx_, key) != 0;
  }
  // The whole config object as JSON text, for values the getters cannot express.
  [[nodiscard]] std::string configJson() const { return api_->config_json(ctx_); }
  // Logs "$.modules[N].config.<key>: <reason>". Then fail init, e.g. throw Failure(SKR_ERR_CONFIG).
  void configError(const char* key, const std::string& reason) const noexcept {
    api_->config_error(ctx_, key, reason.c_str());
  }

  // --- ticks (loop thread, from the constructor until stop()). Throws Failure when refused.
  template <typename F>
  [[nodiscard]] TickHandle onTick(Tick which, F&& fn) {
    TickHandle h;
    h.bound_.reset(new TickHandle::Bound{api_, ctx_, std::function<void()>(std::forward<F>(fn))});
    const skr_status st =
        api_->tick_add(ctx_, static_cast<skr_tick>(which), &runTick, h.bound_.get(), &h.handle_);
    if (st != SKR_OK) throw Failure(st, std::string("tick_add: ") + api_->strerror(st));
    return h;
  }

  // --- work from other threads (any thread). Runs `fn` on the loop thread at a later pulse.
  // The module cannot go on (ABI 1.10; any thread): the host logs MODULE-FAILED with `reason`
  // and soon after stops the module as at shutdown (docs/plugins.md, "A module that cannot go
  // on"). Only the first call counts.
  void fail(const std::string& reason) const noexcept {
    if (api_->abi_minor >= 10) api_->fail(ctx_, reason.c_str());
  }

  // Returns false (and drops fn) when the module is stopping or stopped, or out of memory.
  template <typename F>
  bool post(F&& fn) const noexcept {
    try {
      auto* item = new Posted{api_, ctx_, std::function<void()>(std::forward<F>(fn))};
      if (api_->post(ctx_, &runPosted, &dropPosted, item) == SKR_OK) return true;
      delete item;
    } catch (...) {
    }
    return false;
  }

  // --- time and loop
  [[nodiscard]] std::int64_t nowNs() const noexcept { return api_->now_ns(); }
  [[nodiscard]] const skr_loop_info& loopInfo() const noexcept { return *api_->loop_info(ctx_); }
  [[nodiscard]] std::string_view name() const noexcept { return api_->module_name(ctx_); }

  [[nodiscard]] const skr_host_api* api() const noexcept { return api_; }
  [[nodiscard]] skr_module_ctx* ctx() const noexcept { return ctx_; }

 private:
  struct Posted {
    const skr_host_api* api;
    skr_module_ctx* ctx;
    std::function<void()> fn;
  };

  static void runTick(void* user) noexcept {
    auto* bound = static_cast<TickHandle::Bound*>(user);
    detail::logged(bound->api, bound->ctx, "tick handler", bound->fn);
  }
  static void runPosted(void* user) noexcept {
    std::unique_ptr<Posted> item(static_cast<Posted*>(user));
    detail::logged(item->api, item->ctx, "posted work", item->fn);
  }
  static void dropPosted(void* user) noexcept { delete static_cast<Posted*>(user); }

  const skr_host_api* api_;
  skr_module_ctx* ctx_;
};

// Base class of a C++ module. The constructor Class(Host&) is init: it reads config and may
// throw to refuse. start() and stop() run on the module's loop thread; stop() is only called
// after a successful start() and at most once; the destructor is fini.
class Module {
 public:
  Module() = default;
  Module(const Module&) = delete;
  Module& operator=(const Module&) = delete;
  Module(Module&&) = delete;
  Module& operator=(Module&&) = delete;
  virtual ~Module() = default;

  virtual void start() {}
  virtual void stop() {}
  // ABI 1.11: the config changed while the module runs (Host's config calls read the new one,
  // checked against the declared keys). Return true once applied in place (its channels and
  // state stay); false (the default) to be restarted with it. Runs on the module's loop thread.
  virtual bool reconfigure() { return false; }
};

namespace detail {

// The C lifecycle functions for a Module subclass.
template <typename Class>
struct Adapter {
  struct Instance {
    Instance(const skr_host_api* api, skr_module_ctx* ctx) noexcept : host(api, ctx) {}
    Host host;
    std::unique_ptr<Class> module;
    bool started = false;
  };

  static skr_status init(const skr_host_api* api, skr_module_ctx* ctx, void** out) noexcept {
    if (api == nullptr || ctx == nullptr || out == nullptr) return SKR_ERR_INVALID_ARGUMENT;
    if (api->abi_major != SKR_PLUGIN_ABI_MAJOR || api->struct_size < sizeof(skr_host_api)) {
      return SKR_ERR_UNSUPPORTED;  // a host this header does not know; its table may differ
    }
    Instance* inst = nullptr;
    const skr_status st = guarded(api, ctx, "init", [&] {
      auto owner = std::make_unique<Instance>(api, ctx);
      owner->module = std::make_unique<Class>(owner->host);
      inst = owner.release();
    });
    *out = inst;
    return st;
  }

  static skr_status start(void* instance) noexcept {
    auto* inst = static_cast<Instance*>(instance);
    if (inst->started) return SKR_OK;
    return guarded(inst->host.api(), inst->host.ctx(), "start", [&] {
      inst->module->start();
      inst->started = true;
    });
  }

  static skr_status stop(void* instance) noexcept {
    auto* inst = static_cast<Instance*>(instance);
    if (!inst->started) return SKR_OK;
    inst->started = false;
    return guarded(inst->host.api(), inst->host.ctx(), "stop", [&] { inst->module->stop(); });
  }

  static skr_status reconfigure(void* instance) noexcept {
    auto* inst = static_cast<Instance*>(instance);
    if (!inst->started) return SKR_ERR_UNSUPPORTED;
    bool applied = false;
    const skr_status st = guarded(inst->host.api(), inst->host.ctx(), "reconfigure",
                                  [&] { applied = inst->module->reconfigure(); });
    if (st != SKR_OK) return st;
    return applied ? SKR_OK : SKR_ERR_UNSUPPORTED;
  }

  static void fini(void* instance) noexcept {
    auto* inst = static_cast<Instance*>(instance);
    // A destructor that throws terminates anyway; catch what the members' cleanup may throw.
    logged(inst->host.api(), inst->host.ctx(), "destructor", [&] { inst->module.reset(); });
    delete inst;
  }
};

}  // namespace detail
}  // namespace skr::plugin

// Defines the entry symbol and the descriptor of a module implemented by `Class`.
// `flags` is 0 or SKR_MODULE_* flags, e.g. SKR_MODULE_WANTS_OWN_THREAD. Use once per module.
// The module declares no config keys: its config object reaches it unchecked. To declare them,
// use SKR_MODULE_WITH_CONFIG of <skrobot/support/config.hpp> instead.
#define SKR_MODULE(Class, name, version, description, flags) \
  SKR_MODULE_DESCRIPTOR(Class, name, version, description, flags, nullptr, 0)

// The descriptor itself; `keys` (a static array of skr_config_key, or nullptr) and `key_count`.
#define SKR_MODULE_DESCRIPTOR(Class, name, version, description, flags, keys, key_count) \
  extern "C" SKR_EXPORT const skr_module_descriptor* skrobot_module_entry(void) {        \
    static constexpr skr_module_descriptor kDescriptor = {                               \
        sizeof(skr_module_descriptor),                                                   \
        SKR_PLUGIN_ABI_MAJOR,                                                            \
        SKR_PLUGIN_ABI_MINOR,                                                            \
        (name),                                                                          \
        (version),                                                                       \
        (description),                                                                   \
        static_cast<std::uint64_t>(flags),                                               \
        &::skr::plugin::detail::Adapter<Class>::init,                                    \
        &::skr::plugin::detail::Adapter<Class>::start,                                   \
        &::skr::plugin::detail::Adapter<Class>::stop,                                    \
        &::skr::plugin::detail::Adapter<Class>::fini,                                    \
        (keys),                                                                          \
        static_cast<std::size_t>(key_count),                                             \
        &::skr::plugin::detail::Adapter<Class>::reconfigure};                            \
    return &kDescriptor;                                                                 \
  }

// Deprecated names (the old prefix SKROBOT_): they expand to the SKR_ macros
// with a compiler warning, so that modules written for them build unchanged. Deprecated: these
// aliases go in the next minor release.
#define SKROBOT_MODULE(...) \
  _Pragma("GCC warning \"SKROBOT_MODULE is deprecated: use SKR_MODULE\"") SKR_MODULE(__VA_ARGS__)
#define SKROBOT_MODULE_DESCRIPTOR(...)                                                          \
  _Pragma("GCC warning \"SKROBOT_MODULE_DESCRIPTOR is deprecated: use SKR_MODULE_DESCRIPTOR\"") \
      SKR_MODULE_DESCRIPTOR(__VA_ARGS__)
