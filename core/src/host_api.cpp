// SPDX-License-Identifier: Apache-2.0
// The C table of host services (skr_host_api). Every function is called from module code
// through C frames: none may throw, so each one catches what the C++ below could raise.
#include "module_record.h"

#include <skrobot/runtime/clock.h>
#include <skrobot/runtime/log.h>

#include <json/writer.h>

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>

namespace skr {

// ABI 1.0 as shipped (LP64). A change here breaks every built module: it needs a new major, or
// for a minor, fields appended at the end / reserved slots filled.
#if UINTPTR_MAX == 0xffffffffffffffffu
static_assert(offsetof(skr_module_descriptor, name) == 8);
static_assert(offsetof(skr_module_descriptor, init) == 40);
static_assert(offsetof(skr_module_descriptor, config_keys) == 72);  // 1.0 and 1.1 end here
static_assert(offsetof(skr_module_descriptor, reconfigure) == 88);  // 1.2 to 1.10 end here
static_assert(sizeof(skr_module_descriptor) == 96);                 // 1.11
static_assert(offsetof(skr_host_api, log) == 8);
static_assert(offsetof(skr_host_api, channel_create) == 144);  // 1.0 ends here
static_assert(offsetof(skr_host_api, db_sync) == 224);         // 1.2 ends here
static_assert(offsetof(skr_host_api, blob_get) == 232);        // 1.3 ends here
static_assert(offsetof(skr_host_api, sync_pulse) == 264);      // 1.4 ends here
static_assert(offsetof(skr_host_api, hub_name) == 296);        // 1.5 ends here
static_assert(offsetof(skr_host_api, channel_paths) == 344);   // 1.6 ends here
static_assert(offsetof(skr_host_api, ws_serve) == 368);        // 1.7 ends here
static_assert(offsetof(skr_host_api, ws_close) == 392);        // the last reserved slot (1.8)
static_assert(sizeof(skr_path_options) == 24);
static_assert(sizeof(skr_ws_events) == 32);
static_assert(offsetof(skr_host_api, publish_retained) == 400);  // 1.8 ends here: grows at the end
static_assert(offsetof(skr_host_api, fail) == 416);              // 1.9 ends here
static_assert(sizeof(skr_host_api) == 424);
static_assert(sizeof(skr_loop_info) == 40);
#endif

bool PostQueue::post(const std::shared_ptr<PostQueue>& self, Loop& loop, skr_callback fn,
                     skr_callback cancel, void* user) {
  // Under the lock: once close() returned, no call reaches `loop`, which may be gone by then.
  std::lock_guard lock(mutex_);
  if (!open_) return false;
  items_.push_back(Item{fn, cancel, user});
  try {
    loop.post([self] { self->runOne(); });
  } catch (...) {
    items_.pop_back();
    throw;
  }
  return true;
}

void PostQueue::runOne() {
  Item item{};
  {
    std::lock_guard lock(mutex_);
    if (items_.empty()) return;  // cancelled by close()
    item = items_.front();
    items_.pop_front();
  }
  item.fn(item.user);
}

void PostQueue::close() noexcept {
  std::deque<Item> left;
  {
    std::lock_guard lock(mutex_);
    open_ = false;
    left.swap(items_);
  }
  for (const Item& item : left) {
    if (item.cancel != nullptr) item.cancel(item.user);
  }
}

const char* statusText(skr_status status) noexcept {
  switch (status) {
    case SKR_OK:
      return "ok";
    case SKR_ERR_INVALID_ARGUMENT:
      return "invalid argument";
    case SKR_ERR_NOT_FOUND:
      return "not found";
    case SKR_ERR_FAILED:
      return "failed";
    case SKR_ERR_EXCEPTION:
      return "exception";
    case SKR_ERR_NOT_ON_LOOP_THREAD:
      return "not on the module's loop thread";
    case SKR_ERR_BAD_STATE:
      return "not allowed in this lifecycle step";
    case SKR_ERR_NO_MEMORY:
      return "out of memory";
    case SKR_ERR_UNSUPPORTED:
      return "unsupported";
    case SKR_ERR_CONFIG:
      return "invalid config";
    default:
      return "unknown status";
  }
}

skr_status toStatus(Errc code) noexcept {
  switch (code) {
    case Errc::ok:
      return SKR_OK;
    case Errc::not_found:
    case Errc::owner_gone:
      return SKR_ERR_NOT_FOUND;
    case Errc::invalid_argument:
    case Errc::parse_error:
    case Errc::already_exists:
    case Errc::permission_denied:
      return SKR_ERR_INVALID_ARGUMENT;
    default:
      return SKR_ERR_FAILED;
  }
}

namespace {

std::atomic<skr_tick_handle> g_next_tick_handle{1};

log::Level toLevel(skr_log_level level) noexcept {
  switch (level) {
    case SKR_LOG_DEBUG:
      return log::Level::debug;
    case SKR_LOG_INFO:
      return log::Level::info;
    case SKR_LOG_WARN:
      return log::Level::warn;
    default:
      return log::Level::error;
  }
}

const Json::Value* member(skr_module_ctx* ctx, const char* key) noexcept {
  if (ctx == nullptr || key == nullptr || !ctx->entry.config.isObject()) return nullptr;
  return ctx->entry.config.find(key, key + std::strlen(key));
}

void reportConfig(skr_module_ctx* ctx, const char* key, const char* reason,
                  log::Level level = log::Level::error) noexcept {
  try {
    std::string text = ctx->json_path + ".config." + (key != nullptr ? key : "?") + ": " +
                       (reason != nullptr ? reason : "invalid");
    log::write(level, ctx->log_source, "MODULE-CONFIG", text);
    std::lock_guard lock(ctx->error_mutex);
    ctx->config_error = std::move(text);
  } catch (...) {
  }
}

// A value of the wrong type: say so and let the getter return the default.
void wrongType(skr_module_ctx* ctx, const char* key, const char* expected) noexcept {
  try {
    reportConfig(ctx, key, (std::string("expected ") + expected + ", using the default").c_str(),
                 log::Level::warn);
  } catch (...) {
  }
}

void hostLog(skr_module_ctx* ctx, skr_log_level level, const char* tag,
             const char* message) noexcept {
  if (ctx == nullptr) return;
  try {
    log::write(toLevel(level), ctx->log_source, tag != nullptr ? tag : "",
               message != nullptr ? message : "");
  } catch (...) {
  }
}

int hostLogEnabled(skr_module_ctx*, skr_log_level level) noexcept {
  return log::enabled(toLevel(level));
}

const char* configString(skr_module_ctx* ctx, const char* key, const char* def) noexcept {
  const Json::Value* v = member(ctx, key);
  if (v == nullptr) return def;
  if (!v->isString()) {
    wrongType(ctx, key, "a string");
    return def;
  }
  return v->asCString();  // points into ctx->entry.config, which lives until the ctx does
}

int64_t configInt(skr_module_ctx* ctx, const char* key, int64_t def) noexcept {
  const Json::Value* v = member(ctx, key);
  if (v == nullptr) return def;
  if (!v->isInt64()) {
    wrongType(ctx, key, "an integer");
    return def;
  }
  return v->asInt64();
}

double configDouble(skr_module_ctx* ctx, const char* key, double def) noexcept {
  const Json::Value* v = member(ctx, key);
  if (v == nullptr) return def;
  if (!v->isNumeric()) {
    wrongType(ctx, key, "a number");
    return def;
  }
  return v->asDouble();
}

int configBool(skr_module_ctx* ctx, const char* key, int def) noexcept {
  const Json::Value* v = member(ctx, key);
  if (v == nullptr) return def;
  if (!v->isBool()) {
    wrongType(ctx, key, "true or false");
    return def;
  }
  return v->asBool() ? 1 : 0;
}

int configHas(skr_module_ctx* ctx, const char* key) noexcept {
  return member(ctx, key) != nullptr ? 1 : 0;
}

const char* configJson(skr_module_ctx* ctx) noexcept {
  return ctx != nullptr ? ctx->config_json.c_str() : "{}";
}

void configError(skr_module_ctx* ctx, const char* key, const char* reason) noexcept {
  if (ctx != nullptr) reportConfig(ctx, key, reason);
}

skr_status tickAdd(skr_module_ctx* ctx, skr_tick which, skr_callback fn, void* user,
                   skr_tick_handle* out) noexcept {
  if (ctx == nullptr || fn == nullptr || out == nullptr) return SKR_ERR_INVALID_ARGUMENT;
  if (which != SKR_TICK_FAST && which != SKR_TICK_SLOW && which != SKR_TICK_ONE_SEC) {
    return SKR_ERR_INVALID_ARGUMENT;
  }
  if (!ctx->onLoopThread()) return SKR_ERR_NOT_ON_LOOP_THREAD;
  if (!ctx->accepting) return SKR_ERR_BAD_STATE;
  try {
    // The gate keeps handlers added during init silent until start.
    const TickId id = ctx->loop->addTickHandler(static_cast<Tick>(which), [ctx, fn, user] {
      if (ctx->ticking) fn(user);
    });
    const skr_tick_handle handle = g_next_tick_handle.fetch_add(1);
    ctx->ticks.emplace_back(handle, id);
    *out = handle;
    return SKR_OK;
  } catch (...) {
    return SKR_ERR_NO_MEMORY;
  }
}

skr_status tickRemove(skr_module_ctx* ctx, skr_tick_handle handle) noexcept {
  if (ctx == nullptr) return SKR_ERR_INVALID_ARGUMENT;
  if (!ctx->onLoopThread()) return SKR_ERR_NOT_ON_LOOP_THREAD;
  for (auto it = ctx->ticks.begin(); it != ctx->ticks.end(); ++it) {
    if (it->first == handle) {
      ctx->loop->removeTickHandler(it->second);
      ctx->ticks.erase(it);
      return SKR_OK;
    }
  }
  return SKR_ERR_NOT_FOUND;
}

skr_status post(skr_module_ctx* ctx, skr_callback fn, skr_callback cancel, void* user) noexcept {
  if (ctx == nullptr || fn == nullptr) return SKR_ERR_INVALID_ARGUMENT;
  try {
    return ctx->posts->post(ctx->posts, *ctx->loop, fn, cancel, user) ? SKR_OK : SKR_ERR_BAD_STATE;
  } catch (...) {
    return SKR_ERR_NO_MEMORY;
  }
}

int64_t nowNs() noexcept {
  return monotonicNs();
}

const skr_loop_info* loopInfo(skr_module_ctx* ctx) noexcept {
  return &ctx->loop_info;
}

void setError(skr_module_ctx* ctx, const char* message) noexcept {
  if (ctx == nullptr) return;
  try {
    std::lock_guard lock(ctx->error_mutex);
    ctx->error = message != nullptr ? message : "";
  } catch (...) {
  }
}

const char* strError(skr_status status) noexcept {
  return statusText(status);
}

const char* moduleName(skr_module_ctx* ctx) noexcept {
  return ctx != nullptr ? ctx->name.c_str() : "";
}

// --- FlowNetwork channels and databases (ABI 1.1) ---
// They run on the hub's main loop: the server lives there. The module's ModuleFlow (its
// LocalClient) is made by the first call. A module on its own thread makes them from that
// thread (ABI 1.10; module_calls.h), except those marked OwnThread::refused.
// What every call needs on the main loop: its thread, a hub, and a lifecycle step that may
// register.
skr_status hubCallAllowed(skr_module_ctx* ctx) noexcept {
  if (ctx == nullptr) return SKR_ERR_INVALID_ARGUMENT;
  if (ctx->own_thread || !ctx->onLoopThread()) return SKR_ERR_NOT_ON_LOOP_THREAD;
  if (ctx->server == nullptr) return SKR_ERR_UNSUPPORTED;
  if (!ctx->accepting) return SKR_ERR_BAD_STATE;
  return SKR_OK;
}

// Whether a module on its own thread may make the call (ABI 1.10): those whose callbacks the
// host hands to that thread (ModuleFlow::deliverOn), and those without callbacks.
enum class OwnThread : bool { refused, allowed };

// On the main loop thread.
skr_status runFlow(skr_module_ctx* ctx, const std::function<skr_status(ModuleFlow&)>& fn) noexcept {
  try {
    if (!ctx->flow) {
      ctx->flow = std::make_unique<ModuleFlow>(*ctx->server, ctx->name, ctx->access);
      if (ctx->own_thread) ctx->flow->deliverOn(*ctx->loop);
    }
    return fn(*ctx->flow);
  } catch (...) {
    return SKR_ERR_NO_MEMORY;
  }
}

skr_status withFlow(skr_module_ctx* ctx, const std::function<skr_status(ModuleFlow&)>& fn,
                    OwnThread own = OwnThread::allowed) noexcept {
  if (ctx != nullptr && ctx->own_thread && ctx->calls && ctx->onLoopThread()) {
    // The module's own thread: the call runs on the main loop while this thread waits.
    if (own == OwnThread::refused) return SKR_ERR_NOT_ON_LOOP_THREAD;
    if (ctx->server == nullptr) return SKR_ERR_UNSUPPORTED;
    if (!ctx->accepting) return SKR_ERR_BAD_STATE;
    try {
      return ctx->calls->call([ctx, &fn] { return runFlow(ctx, fn); });
    } catch (...) {
      return SKR_ERR_NO_MEMORY;
    }
  }
  if (const skr_status st = hubCallAllowed(ctx); st != SKR_OK) return st;
  return runFlow(ctx, fn);
}

skr_status channelCreate(skr_module_ctx* ctx, const char* short_name, skr_channel_kind kind,
                         const char* mime, const char* props_json, skr_subscribers_fn on_subs,
                         skr_request_fn on_request, void* user, uint16_t* out) noexcept {
  return withFlow(ctx, [&](ModuleFlow& f) {
    return f.createChannel(short_name, kind, mime, props_json, on_subs, on_request, user, out);
  });
}
skr_status channelRemove(skr_module_ctx* ctx, uint16_t chan_id) noexcept {
  return withFlow(ctx, [&](ModuleFlow& f) { return f.removeChannel(chan_id); });
}
skr_status channelFind(skr_module_ctx* ctx, const char* name, uint16_t* out) noexcept {
  return withFlow(ctx, [&](ModuleFlow& f) { return f.findChannel(name, out); });
}
skr_status publishData(skr_module_ctx* ctx, uint16_t chan_id, const void* data,
                       size_t size) noexcept {
  return withFlow(ctx, [&](ModuleFlow& f) { return f.publish(chan_id, data, size); });
}
skr_status subscribeChannel(skr_module_ctx* ctx, const char* name, skr_data_fn fn, void* user,
                            skr_sub_handle* out) noexcept {
  return withFlow(ctx, [&](ModuleFlow& f) { return f.subscribe(name, fn, user, out); });
}
skr_status unsubscribeChannel(skr_module_ctx* ctx, skr_sub_handle handle) noexcept {
  return withFlow(ctx, [&](ModuleFlow& f) { return f.unsubscribe(handle); });
}
skr_status serviceRequest(skr_module_ctx* ctx, uint16_t chan_id, uint32_t tag, const char* command,
                          const char* value_json, skr_response_fn fn, void* user) noexcept {
  return withFlow(
      ctx, [&](ModuleFlow& f) { return f.request(chan_id, tag, command, value_json, fn, user); });
}
skr_status serviceRespond(skr_module_ctx* ctx, uint16_t chan_id, uint64_t request,
                          const char* value_json) noexcept {
  return withFlow(ctx, [&](ModuleFlow& f) { return f.respond(chan_id, request, value_json); });
}
skr_status dbGet(skr_module_ctx* ctx, const char* db, const char* key, char* buf, size_t cap,
                 size_t* len_out) noexcept {
  return withFlow(ctx, [&](ModuleFlow& f) { return f.dbGet(db, key, buf, cap, len_out); });
}
skr_status dbSet(skr_module_ctx* ctx, const char* db, const char* key,
                 const char* value_json) noexcept {
  return withFlow(ctx, [&](ModuleFlow& f) { return f.dbSet(db, key, value_json); });
}
skr_status dbSync(skr_module_ctx* ctx, skr_done_fn fn, void* user) noexcept {
  return withFlow(
      ctx, [&](ModuleFlow& f) { return f.dbSync(fn, user); }, OwnThread::refused);
}
skr_status blobGet(skr_module_ctx* ctx, uint16_t chan_id, const char* path, uint64_t max_bytes,
                   skr_blob_fn fn, void* user) noexcept {
  return withFlow(
      ctx, [&](ModuleFlow& f) { return f.blobGet(chan_id, path, max_bytes, fn, user); },
      OwnThread::refused);
}
skr_status blobPut(skr_module_ctx* ctx, uint16_t chan_id, const char* path, const void* data,
                   size_t size, skr_blob_fn fn, void* user) noexcept {
  return withFlow(
      ctx, [&](ModuleFlow& f) { return f.blobPut(chan_id, path, data, size, fn, user); },
      OwnThread::refused);
}
skr_status blobList(skr_module_ctx* ctx, uint16_t chan_id, const char* dir, skr_blob_fn fn,
                    void* user) noexcept {
  return withFlow(
      ctx, [&](ModuleFlow& f) { return f.blobList(chan_id, dir, fn, user); }, OwnThread::refused);
}
skr_status blobDo(skr_module_ctx* ctx, uint16_t chan_id, skr_blob_op op, const char* path,
                  skr_blob_fn fn, void* user) noexcept {
  return withFlow(
      ctx, [&](ModuleFlow& f) { return f.blobDo(chan_id, op, path, fn, user); },
      OwnThread::refused);
}
skr_status syncPulse(skr_module_ctx* ctx, uint16_t chan_id) noexcept {
  return withFlow(ctx, [&](ModuleFlow& f) { return f.syncPulse(chan_id); });
}
skr_status syncFollow(skr_module_ctx* ctx, const char* name, uint32_t every, uint32_t flags,
                      skr_sync_fn fn, void* user, skr_sub_handle* out) noexcept {
  return withFlow(
      ctx, [&](ModuleFlow& f) { return f.syncFollow(name, every, flags, fn, user, out); },
      OwnThread::refused);
}
skr_status syncUnfollow(skr_module_ctx* ctx, skr_sub_handle handle) noexcept {
  return withFlow(
      ctx, [&](ModuleFlow& f) { return f.syncUnfollow(handle); }, OwnThread::refused);
}
skr_status syncDone(skr_module_ctx* ctx, skr_sub_handle handle, uint64_t seq) noexcept {
  return withFlow(
      ctx, [&](ModuleFlow& f) { return f.syncDone(handle, seq); }, OwnThread::refused);
}

const char* hubName(skr_module_ctx* ctx) noexcept {
  return ctx != nullptr && ctx->server != nullptr ? ctx->server->hubName().c_str() : "";
}
skr_status channelWatch(skr_module_ctx* ctx, skr_channel_fn fn, void* user,
                        skr_sub_handle* out) noexcept {
  return withFlow(ctx, [&](ModuleFlow& f) { return f.channelWatch(fn, user, out); });
}
skr_status channelUnwatch(skr_module_ctx* ctx, skr_sub_handle handle) noexcept {
  return withFlow(ctx, [&](ModuleFlow& f) { return f.channelUnwatch(handle); });
}
skr_status dbWatch(skr_module_ctx* ctx, const char* db, skr_db_change_fn fn, void* user,
                   skr_sub_handle* out) noexcept {
  return withFlow(
      ctx, [&](ModuleFlow& f) { return f.dbWatch(db, fn, user, out); }, OwnThread::refused);
}
skr_status dbUnwatch(skr_module_ctx* ctx, skr_sub_handle handle) noexcept {
  return withFlow(
      ctx, [&](ModuleFlow& f) { return f.dbUnwatch(handle); }, OwnThread::refused);
}
skr_status dbRemove(skr_module_ctx* ctx, const char* db, const char* key) noexcept {
  return withFlow(ctx, [&](ModuleFlow& f) { return f.dbRemove(db, key); });
}

skr_status channelPaths(skr_module_ctx* ctx, uint16_t chan_id,
                        const skr_path_options* options) noexcept {
  return withFlow(
      ctx, [&](ModuleFlow& f) { return f.offerPaths(*ctx->loop, chan_id, options); },
      OwnThread::refused);
}
skr_status publishRetained(skr_module_ctx* ctx, uint16_t chan_id, const char* key, const void* data,
                           size_t size) noexcept {
  return withFlow(ctx, [&](ModuleFlow& f) { return f.publishRetained(chan_id, key, data, size); });
}
skr_status retainClear(skr_module_ctx* ctx, uint16_t chan_id, const char* key) noexcept {
  return withFlow(ctx, [&](ModuleFlow& f) { return f.retainClear(chan_id, key); });
}
skr_status publishBegin(skr_module_ctx* ctx, uint16_t chan_id, void** slot_out,
                        size_t* capacity_out) noexcept {
  return withFlow(
      ctx, [&](ModuleFlow& f) { return f.publishBegin(chan_id, slot_out, capacity_out); },
      OwnThread::refused);
}
skr_status publishCommit(skr_module_ctx* ctx, uint16_t chan_id, size_t size,
                         int64_t capture_ns) noexcept {
  return withFlow(
      ctx, [&](ModuleFlow& f) { return f.publishCommit(chan_id, size, capture_ns); },
      OwnThread::refused);
}

// The web calls (ABI 1.8).
skr_status withWeb(skr_module_ctx* ctx,
                   const std::function<skr_status(ModuleWebSockets&)>& fn) noexcept {
  if (const skr_status st = hubCallAllowed(ctx); st != SKR_OK) return st;
  try {
    if (!ctx->web) ctx->web = std::make_unique<ModuleWebSockets>(*ctx->server, ctx->log_source);
    return fn(*ctx->web);
  } catch (...) {
    return SKR_ERR_NO_MEMORY;
  }
}

skr_status wsServe(skr_module_ctx* ctx, const char* path, const char* subprotocol,
                   size_t max_message_bytes, size_t max_queued_bytes, const skr_ws_events* events,
                   void* user, skr_sub_handle* out) noexcept {
  return withWeb(ctx, [&](ModuleWebSockets& w) {
    return w.serve(path, subprotocol, max_message_bytes, max_queued_bytes, events, user, out);
  });
}
skr_status wsUnserve(skr_module_ctx* ctx, skr_sub_handle handle) noexcept {
  return withWeb(ctx, [&](ModuleWebSockets& w) { return w.unserve(handle); });
}
skr_status wsSend(skr_module_ctx* ctx, skr_ws_conn conn, int text, const void* data, size_t size,
                  int droppable) noexcept {
  return withWeb(ctx, [&](ModuleWebSockets& w) {
    return w.send(conn, text != 0, data, size, droppable != 0);
  });
}
skr_status wsClose(skr_module_ctx* ctx, skr_ws_conn conn, uint16_t code,
                   const char* reason) noexcept {
  return withWeb(ctx, [&](ModuleWebSockets& w) { return w.close(conn, code, reason); });
}

// ABI 1.10: the module cannot go on.
void moduleFail(skr_module_ctx* ctx, const char* reason) noexcept {
  if (ctx == nullptr || ctx->failed.exchange(true) || !ctx->on_fail) return;
  try {
    ctx->on_fail(reason != nullptr && *reason != '\0' ? reason : "the module failed");
  } catch (...) {
  }
}

const skr_host_api kHostApi = {
    .struct_size = sizeof(skr_host_api),
    .abi_major = SKR_PLUGIN_ABI_MAJOR,
    .abi_minor = SKR_PLUGIN_ABI_MINOR,
    .log = &hostLog,
    .log_enabled = &hostLogEnabled,
    .config_string = &configString,
    .config_int = &configInt,
    .config_double = &configDouble,
    .config_bool = &configBool,
    .config_has = &configHas,
    .config_json = &configJson,
    .config_error = &configError,
    .tick_add = &tickAdd,
    .tick_remove = &tickRemove,
    .post = &post,
    .now_ns = &nowNs,
    .loop_info = &loopInfo,
    .set_error = &setError,
    .strerror = &strError,
    .module_name = &moduleName,
    .channel_create = &channelCreate,
    .channel_remove = &channelRemove,
    .channel_find = &channelFind,
    .publish = &publishData,
    .subscribe = &subscribeChannel,
    .unsubscribe = &unsubscribeChannel,
    .service_request = &serviceRequest,
    .service_respond = &serviceRespond,
    .db_get = &dbGet,
    .db_set = &dbSet,
    .db_sync = &dbSync,
    .blob_get = &blobGet,
    .blob_put = &blobPut,
    .blob_list = &blobList,
    .blob_do = &blobDo,
    .sync_pulse = &syncPulse,
    .sync_follow = &syncFollow,
    .sync_unfollow = &syncUnfollow,
    .sync_done = &syncDone,
    .hub_name = &hubName,
    .channel_watch = &channelWatch,
    .channel_unwatch = &channelUnwatch,
    .db_watch = &dbWatch,
    .db_unwatch = &dbUnwatch,
    .db_remove = &dbRemove,
    .channel_paths = &channelPaths,
    .publish_begin = &publishBegin,
    .publish_commit = &publishCommit,
    .ws_serve = &wsServe,
    .ws_unserve = &wsUnserve,
    .ws_send = &wsSend,
    .ws_close = &wsClose,
    .publish_retained = &publishRetained,
    .retain_clear = &retainClear,
    .fail = &moduleFail,
};

}  // namespace

const skr_host_api* hostApi() noexcept {
  return &kHostApi;
}

}  // namespace skr
