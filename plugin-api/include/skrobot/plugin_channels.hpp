// SPDX-License-Identifier: Apache-2.0
// C++ helpers over the FlowNetwork calls of the plugin ABI (1.1): owned channels, subscriptions,
// service requests and databases. Header-only, inside the module like plugin.hpp.
//
//   out_ = skr::plugin::StreamChannel(host_, "faces", "application/json", R"({"units":"px"})");
//   sub_ = skr::plugin::Subscription(host_, "video-source.video",
//                                    [this](std::string_view frame) { onFrame(frame); });
//   out_.publish(json);
//
// Everything here is for the module's loop thread, from start() until stop() (the host refuses
// earlier and later calls). Destroy the objects in stop() or with the module: they unregister
// themselves, and the host removes whatever is left when the module stops. Calls that fail throw
// Failure (creation) or return false (publish, respond, dbSet) after logging why.
#pragma once

#include <skrobot/plugin.hpp>

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <utility>

namespace skr::plugin {

namespace detail {

// Throws unless the host has the calls of ABI 1.<minor> (`present`: the one the caller needs
// is not NULL), named `what` in the error.
inline void requireAbi(const Host& host, unsigned minor, bool present, const char* what) {
  if (host.api()->abi_minor < minor || !present) {
    throw Failure(SKR_ERR_UNSUPPORTED, std::string("this hub has no ") + what +
                                           " (plugin ABI < 1." + std::to_string(minor) + ")");
  }
}

inline void requireFlow(const Host& host) {
  requireAbi(host, 1, host.api()->channel_create != nullptr, "FlowNetwork calls");
}

inline void check(const Host& host, skr_status st, const std::string& what) {
  if (st != SKR_OK) throw Failure(st, what + ": " + host.api()->strerror(st));
}

}  // namespace detail

// A streaming channel this module owns, "<module name>.<short name>". Removed when destroyed.
class StreamChannel {
 public:
  // Called with true when the first subscriber arrives, false when the last one leaves.
  using SubscribersFn = std::function<void(bool first)>;

  StreamChannel() = default;
  StreamChannel(Host& host, const std::string& short_name, const std::string& mime,
                const std::string& props_json = "{}", SubscribersFn on_subscribers = {})
      : state_(std::make_unique<State>(State{host, 0, std::move(on_subscribers), 0})) {
    detail::requireFlow(host);
    detail::check(host,
                  host.api()->channel_create(host.ctx(), short_name.c_str(), SKR_CHANNEL_STREAMING,
                                             mime.c_str(), props_json.c_str(), &subscribers,
                                             nullptr, state_.get(), &state_->id),
                  "channel_create " + short_name);
    name_ = std::string(host.name()) + "." + short_name;
  }
  StreamChannel(StreamChannel&&) noexcept = default;
  StreamChannel& operator=(StreamChannel&& other) noexcept {
    reset();
    state_ = std::move(other.state_);
    name_ = std::move(other.name_);
    return *this;
  }
  StreamChannel(const StreamChannel&) = delete;
  StreamChannel& operator=(const StreamChannel&) = delete;
  ~StreamChannel() { reset(); }

  // Sends `data` to every subscriber (modules get it without a copy).
  bool publish(const void* data, std::size_t size) noexcept {
    if (!state_) return false;
    return state_->host.api()->publish(state_->host.ctx(), state_->id, data, size) == SKR_OK;
  }
  bool publish(std::string_view data) noexcept { return publish(data.data(), data.size()); }

  // Retained messages (ABI 1.9; docs/plugins.md, "Retained messages"): publishes `data` and
  // keeps it under `key`, replacing what was kept there; every later subscriber gets all kept
  // messages, oldest first, before live ones. False when the host is older than 1.9 or refuses
  // (over 64 keys or 16 MiB on the channel: logged by the host).
  bool publishRetained(std::string_view key, std::string_view data) noexcept {
    if (!state_ || state_->host.api()->abi_minor < 9) return false;
    const std::string k(key);
    return state_->host.api()->publish_retained(state_->host.ctx(), state_->id, k.c_str(),
                                                data.data(), data.size()) == SKR_OK;
  }
  // Forgets the message kept under `key` (every one when `key` is empty).
  bool clearRetained(std::string_view key = {}) noexcept {
    if (!state_ || state_->host.api()->abi_minor < 9) return false;
    const std::string k(key);
    return state_->host.api()->retain_clear(state_->host.ctx(), state_->id,
                                            key.empty() ? nullptr : k.c_str()) == SKR_OK;
  }

  // Physical mode (ABI 1.7; docs/physical-mode.md, "Modules"): the hub serves this channel's
  // subscribers on its machine by shared memory (SKR_PATH_SHM: a ring of `slots` slots of
  // `slot_bytes`, the largest message) and/or a direct socket (SKR_PATH_DIRECT); publish() keeps
  // working. Once per channel. Throws Failure (SKR_ERR_UNSUPPORTED from a hub older than 1.7).
  void offerPaths(std::uint32_t kinds, std::uint64_t slot_bytes, std::uint32_t slots = 4) {
    if (!state_) throw Failure(SKR_ERR_BAD_STATE, "offerPaths on an empty StreamChannel");
    const Host& host = state_->host;
    detail::requireAbi(host, 7, host.api()->channel_paths != nullptr, "physical paths");
    skr_path_options o{};
    o.struct_size = sizeof o;
    o.kinds = kinds;
    o.ring_slots = slots;
    o.slot_bytes = slot_bytes;
    detail::check(host, host.api()->channel_paths(host.ctx(), state_->id, &o),
                  "channel_paths " + name_);
  }
  // A shared-memory slot to fill in place, then commitPublish(size) it; empty when there is
  // none (no ring, a hub older than 1.7, every slot being read): publish() a copy instead.
  [[nodiscard]] std::span<std::byte> beginPublish() noexcept {
    if (!state_ || state_->host.api()->abi_minor < 7) return {};
    void* slot = nullptr;
    std::size_t cap = 0;
    if (state_->host.api()->publish_begin(state_->host.ctx(), state_->id, &slot, &cap) != SKR_OK) {
      return {};
    }
    return {static_cast<std::byte*>(slot), cap};
  }
  // Publishes the first `size` bytes of the slot beginPublish gave; `capture_ns`: the message's
  // own time (monotonic), or 0.
  bool commitPublish(std::size_t size, std::int64_t capture_ns = 0) noexcept {
    if (!state_ || state_->host.api()->abi_minor < 7) return false;
    return state_->host.api()->publish_commit(state_->host.ctx(), state_->id, size, capture_ns) ==
           SKR_OK;
  }

  // Number of subscribers as far as the first/last notifications tell: 0 or 1 ("some").
  [[nodiscard]] bool hasSubscribers() const noexcept { return state_ && state_->subscribed != 0; }
  [[nodiscard]] std::uint16_t id() const noexcept { return state_ ? state_->id : 0; }
  [[nodiscard]] const std::string& name() const noexcept { return name_; }
  [[nodiscard]] bool valid() const noexcept { return state_ != nullptr; }

  void reset() noexcept {
    if (!state_) return;
    state_->host.api()->channel_remove(state_->host.ctx(), state_->id);  // NOT_FOUND after stop
    state_.reset();
  }

 private:
  struct State {
    Host host;
    std::uint16_t id;
    SubscribersFn on_subscribers;
    int subscribed;
  };
  static void subscribers(void* user, std::uint16_t /*chan*/, int first) noexcept {
    auto* s = static_cast<State*>(user);
    s->subscribed = first;
    if (s->on_subscribers) {
      detail::logged(s->host.api(), s->host.ctx(), "subscribers callback",
                     [&] { s->on_subscribers(first != 0); });
    }
  }

  std::unique_ptr<State> state_;
  std::string name_;
};

// One request to a service channel this module owns. Answer it once, now or later, through
// ServiceChannel::respond (keep `id`).
struct ServiceRequest {
  std::uint64_t id = 0;
  std::string command;
  std::string requester;   // the requesting flow's user (or module) name
  std::string value_json;  // the request's value as JSON text
};

// A service channel this module owns: requests arrive on the loop thread. Removed when destroyed;
// requests not answered by then fail for their callers.
class ServiceChannel {
 public:
  using RequestFn = std::function<void(const ServiceRequest&)>;

  ServiceChannel() = default;
  ServiceChannel(Host& host, const std::string& short_name, RequestFn on_request,
                 const std::string& props_json = "{}")
      : state_(std::make_unique<State>(State{host, 0, std::move(on_request)})) {
    detail::requireFlow(host);
    detail::check(host,
                  host.api()->channel_create(host.ctx(), short_name.c_str(), SKR_CHANNEL_SERVICE,
                                             "application/json", props_json.c_str(), nullptr,
                                             &request, state_.get(), &state_->id),
                  "channel_create " + short_name);
    name_ = std::string(host.name()) + "." + short_name;
  }
  ServiceChannel(ServiceChannel&&) noexcept = default;
  ServiceChannel& operator=(ServiceChannel&& other) noexcept {
    reset();
    state_ = std::move(other.state_);
    name_ = std::move(other.name_);
    return *this;
  }
  ServiceChannel(const ServiceChannel&) = delete;
  ServiceChannel& operator=(const ServiceChannel&) = delete;
  ~ServiceChannel() { reset(); }

  // The answer to request `id`: a JSON value (an object by convention, e.g. {"ok":true} or
  // {"error":"..."}). False when it could not be sent (the requester is gone, or bad JSON).
  bool respond(std::uint64_t id, const std::string& value_json) noexcept {
    if (!state_) return false;
    return state_->host.api()->service_respond(state_->host.ctx(), state_->id, id,
                                               value_json.c_str()) == SKR_OK;
  }

  [[nodiscard]] std::uint16_t id() const noexcept { return state_ ? state_->id : 0; }
  [[nodiscard]] const std::string& name() const noexcept { return name_; }

  void reset() noexcept {
    if (!state_) return;
    state_->host.api()->channel_remove(state_->host.ctx(), state_->id);
    state_.reset();
  }

 private:
  struct State {
    Host host;
    std::uint16_t id;
    RequestFn on_request;
  };
  static void request(void* user, std::uint16_t /*chan*/, std::uint64_t id, const char* command,
                      const char* requester, const char* value_json) noexcept {
    auto* s = static_cast<State*>(user);
    detail::logged(s->host.api(), s->host.ctx(), "request handler", [&] {
      s->on_request(ServiceRequest{id, command != nullptr ? command : "",
                                   requester != nullptr ? requester : "",
                                   value_json != nullptr ? value_json : "null"});
    });
  }

  std::unique_ptr<State> state_;
  std::string name_;
};

// A subscription to a streaming channel by full name ("<owner>.<name>"). It waits for a channel
// that does not exist yet and follows it when it is removed and created again. The payload view
// is valid only during the callback: copy what you keep.
class Subscription {
 public:
  using DataFn = std::function<void(std::string_view payload)>;

  Subscription() = default;
  Subscription(Host& host, const std::string& channel, DataFn on_data)
      : state_(std::make_unique<State>(State{host, std::move(on_data)})) {
    detail::requireFlow(host);
    detail::check(host,
                  host.api()->subscribe(host.ctx(), channel.c_str(), &data, state_.get(), &handle_),
                  "subscribe " + channel);
  }
  Subscription(Subscription&& other) noexcept { swap(other); }
  Subscription& operator=(Subscription&& other) noexcept {
    Subscription(std::move(other)).swap(*this);
    return *this;
  }
  Subscription(const Subscription&) = delete;
  Subscription& operator=(const Subscription&) = delete;
  ~Subscription() { reset(); }

  void reset() noexcept {
    if (handle_ != 0) state_->host.api()->unsubscribe(state_->host.ctx(), handle_);
    handle_ = 0;
    state_.reset();
  }
  [[nodiscard]] bool active() const noexcept { return handle_ != 0; }

 private:
  struct State {
    Host host;
    DataFn on_data;
  };
  static void data(void* user, std::uint16_t /*chan*/, const void* bytes,
                   std::size_t size) noexcept {
    auto* s = static_cast<State*>(user);
    detail::logged(s->host.api(), s->host.ctx(), "data handler",
                   [&] { s->on_data(std::string_view(static_cast<const char*>(bytes), size)); });
  }
  void swap(Subscription& other) noexcept {
    std::swap(state_, other.state_);
    std::swap(handle_, other.handle_);
  }

  std::unique_ptr<State> state_;
  skr_sub_handle handle_ = 0;
};

// Requests to other modules' or satellites' service channels. Keep one Requester for the module's
// life (destroy it in stop() or with the module): the host drops unanswered requests when the
// module stops, and answers arriving after the Requester is gone must not find it destroyed
// while the module still runs.
class Requester {
 public:
  // ok: the owner answered with value_json; !ok: value_json is a JSON string saying why not
  // (no such channel, owner gone, overflow).
  using ResponseFn = std::function<void(bool ok, const std::string& value_json)>;

  explicit Requester(Host& host) : state_(std::make_unique<State>(State{host, {}, 1})) {}

  // Sends `command` with a JSON value to the service channel named `channel`. False (and `fn` is
  // never called) when the channel does not exist now or the value is not valid JSON.
  bool request(const std::string& channel, const std::string& command,
               const std::string& value_json, ResponseFn fn = {}) {
    const skr_host_api* api = state_->host.api();
    std::uint16_t chan = 0;
    if (api->channel_find(state_->host.ctx(), channel.c_str(), &chan) != SKR_OK) return false;
    const std::uint32_t tag = state_->next_tag++;
    if (fn) state_->waiting.emplace(tag, std::move(fn));
    const skr_status st = api->service_request(state_->host.ctx(), chan, tag, command.c_str(),
                                               value_json.c_str(), &response, state_.get());
    if (st != SKR_OK) state_->waiting.erase(tag);
    return st == SKR_OK;
  }
  [[nodiscard]] std::size_t pending() const noexcept { return state_->waiting.size(); }

 private:
  struct State {
    Host host;
    std::map<std::uint32_t, ResponseFn> waiting;
    std::uint32_t next_tag;
  };
  static void response(void* user, std::uint16_t /*chan*/, std::uint32_t tag, skr_status status,
                       const char* value_json) noexcept {
    auto* s = static_cast<State*>(user);
    auto it = s->waiting.find(tag);
    if (it == s->waiting.end()) return;
    ResponseFn fn = std::move(it->second);
    s->waiting.erase(it);
    detail::logged(s->host.api(), s->host.ctx(), "response handler",
                   [&] { fn(status == SKR_OK, value_json != nullptr ? value_json : "null"); });
  }

  std::unique_ptr<State> state_;
};

// Databases (loop thread): a variable as JSON text, or nullopt when the database or key is missing.
inline std::optional<std::string> dbGet(const Host& host, const std::string& db,
                                        const std::string& key) {
  const skr_host_api* api = host.api();
  std::string buf(256, '\0');
  std::size_t need = 0;
  skr_status st = api->db_get(host.ctx(), db.c_str(), key.c_str(), buf.data(), buf.size(), &need);
  if (st == SKR_ERR_NO_MEMORY && need > buf.size()) {
    buf.assign(need, '\0');
    st = api->db_get(host.ctx(), db.c_str(), key.c_str(), buf.data(), buf.size(), &need);
  }
  if (st != SKR_OK) return std::nullopt;
  buf.resize(need > 0 ? need - 1 : 0);
  return buf;
}

// Sets a variable (JSON text) of a database the module may write: its own "<module name>", its
// channels' databases ("<module name>.<channel>"), and named ones. Logs and returns false on error.
inline bool dbSet(const Host& host, const std::string& db, const std::string& key,
                  const std::string& value_json) noexcept {
  return host.api()->db_set(host.ctx(), db.c_str(), key.c_str(), value_json.c_str()) == SKR_OK;
}

// A barrier (plugin ABI 1.3): `done(true)` on the loop thread once every database change made so
// far (this module's dbSet calls among them) is on disk, whatever the hub's durability policy;
// `done(false)` when writing failed or the module stopped first. Returns false, and `done` is
// never called, when the host is older than 1.3 or refuses the call.
inline bool dbSync(const Host& host, std::function<void(bool ok)> done) {
  const skr_host_api* api = host.api();
  if (api->abi_minor < 3 || api->db_sync == nullptr) return false;
  struct Waiting {
    const skr_host_api* api;
    skr_module_ctx* ctx;
    std::function<void(bool)> fn;
  };
  auto* waiting = new Waiting{api, host.ctx(), std::move(done)};
  const skr_status st = api->db_sync(
      host.ctx(),
      [](void* user, skr_status status) noexcept {
        const std::unique_ptr<Waiting> w(static_cast<Waiting*>(user));
        if (w->fn)
          detail::logged(w->api, w->ctx, "db_sync handler", [&] { w->fn(status == SKR_OK); });
      },
      waiting);
  if (st != SKR_OK) delete waiting;
  return st == SKR_OK;
}

}  // namespace skr::plugin
