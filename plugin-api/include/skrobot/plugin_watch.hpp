// SPDX-License-Identifier: Apache-2.0
// C++ helpers over the watching calls of the plugin ABI (1.6): channels added and removed,
// changes of a database, a variable's removal and the hub's name. Header-only, inside the module
// like plugin.hpp; loop thread, from start() until stop(), as plugin_channels.hpp.
//
//   watch_ = skr::plugin::ChannelWatch(host_, [this](const skr::plugin::ChannelEvent& ev) {
//     if (ev.added && ev.kind == SKR_CHANNEL_STREAMING) export(ev.name);
//   });
//   db_ = skr::plugin::DatabaseWatch(host_, "calibration",
//       [this](const std::string& key, const std::optional<std::string>& value_json) { ... });
#pragma once

#include <skrobot/plugin_channels.hpp>

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <utility>

namespace skr::plugin {

namespace detail {
inline void requireWatch(const Host& host) {
  requireAbi(host, 6, host.api()->channel_watch != nullptr, "watching calls");
}
}  // namespace detail

// This hub's name ("" from a host older than ABI 1.6).
inline std::string hubName(const Host& host) {
  if (host.api()->abi_minor < 6 || host.api()->hub_name == nullptr) return {};
  return host.api()->hub_name(host.ctx());
}

// Removes a variable where dbSet may write. False (logged by the host) on error.
inline bool dbRemove(const Host& host, const std::string& db, const std::string& key) noexcept {
  if (host.api()->abi_minor < 6 || host.api()->db_remove == nullptr) return false;
  return host.api()->db_remove(host.ctx(), db.c_str(), key.c_str()) == SKR_OK;
}

struct ChannelEvent {
  std::uint16_t id;
  std::string name;
  skr_channel_kind kind;
  std::string mime;
  bool added;
};

// Every channel there is (during construction), then each one added or removed, until destroyed.
class ChannelWatch {
 public:
  using Fn = std::function<void(const ChannelEvent&)>;

  ChannelWatch() = default;
  ChannelWatch(Host& host, Fn fn) : state_(std::make_unique<State>(State{host, std::move(fn)})) {
    detail::requireWatch(host);
    detail::check(host, host.api()->channel_watch(host.ctx(), &event, state_.get(), &handle_),
                  "channel_watch");
  }
  ChannelWatch(ChannelWatch&& other) noexcept { swap(other); }
  ChannelWatch& operator=(ChannelWatch&& other) noexcept {
    ChannelWatch(std::move(other)).swap(*this);
    return *this;
  }
  ChannelWatch(const ChannelWatch&) = delete;
  ChannelWatch& operator=(const ChannelWatch&) = delete;
  ~ChannelWatch() { reset(); }

  void reset() noexcept {
    if (handle_ != 0) state_->host.api()->channel_unwatch(state_->host.ctx(), handle_);
    handle_ = 0;
    state_.reset();
  }

 private:
  struct State {
    Host host;
    Fn fn;
  };
  static void event(void* user, std::uint16_t id, const char* name, skr_channel_kind kind,
                    const char* mime, int added) noexcept {
    auto* s = static_cast<State*>(user);
    detail::logged(s->host.api(), s->host.ctx(), "channel watch", [&] {
      s->fn(ChannelEvent{id, name != nullptr ? name : "", kind, mime != nullptr ? mime : "",
                         added != 0});
    });
  }
  void swap(ChannelWatch& other) noexcept {
    std::swap(state_, other.state_);
    std::swap(handle_, other.handle_);
  }

  std::unique_ptr<State> state_;
  skr_sub_handle handle_ = 0;
};

// Every pair of a database (during construction), then each change, until destroyed: `key` set
// to the JSON text `value`, or removed (nullopt); an empty key with nullopt: the database was
// cleared. Do not change that database from the callback (post the change instead).
class DatabaseWatch {
 public:
  using Fn = std::function<void(const std::string& key, const std::optional<std::string>& value)>;

  DatabaseWatch() = default;
  DatabaseWatch(Host& host, const std::string& db, Fn fn)
      : state_(std::make_unique<State>(State{host, std::move(fn)})) {
    detail::requireWatch(host);
    detail::check(host,
                  host.api()->db_watch(host.ctx(), db.c_str(), &change, state_.get(), &handle_),
                  "db_watch " + db);
  }
  DatabaseWatch(DatabaseWatch&& other) noexcept { swap(other); }
  DatabaseWatch& operator=(DatabaseWatch&& other) noexcept {
    DatabaseWatch(std::move(other)).swap(*this);
    return *this;
  }
  DatabaseWatch(const DatabaseWatch&) = delete;
  DatabaseWatch& operator=(const DatabaseWatch&) = delete;
  ~DatabaseWatch() { reset(); }

  void reset() noexcept {
    if (handle_ != 0) state_->host.api()->db_unwatch(state_->host.ctx(), handle_);
    handle_ = 0;
    state_.reset();
  }

 private:
  struct State {
    Host host;
    Fn fn;
  };
  static void change(void* user, const char* /*db*/, const char* key,
                     const char* value_json) noexcept {
    auto* s = static_cast<State*>(user);
    detail::logged(s->host.api(), s->host.ctx(), "database watch", [&] {
      s->fn(key != nullptr ? key : "",
            value_json != nullptr ? std::optional<std::string>(value_json) : std::nullopt);
    });
  }
  void swap(DatabaseWatch& other) noexcept {
    std::swap(state_, other.state_);
    std::swap(handle_, other.handle_);
  }

  std::unique_ptr<State> state_;
  skr_sub_handle handle_ = 0;
};

}  // namespace skr::plugin
