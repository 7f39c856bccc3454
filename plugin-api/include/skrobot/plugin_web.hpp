// SPDX-License-Identifier: Apache-2.0
// C++ helper over the web calls of the plugin ABI (1.8): a WebSocket endpoint on the hub's web
// port, where browsers reach the module beside the pages and FlowProtocol (/flow). Header-only,
// inside the module like plugin.hpp; loop thread, from start() until stop(), as
// plugin_channels.hpp.
//
//   skr::plugin::WebSocketEndpoint::Events ev;
//   ev.message = [this](skr_ws_conn c, bool text, std::string_view data) { ... };
//   ws_ = skr::plugin::WebSocketEndpoint(host_, "/ws", "skrobot-avatar.v1", 1 << 20, 8 << 20, ev);
//   ws_.send(conn, true, R"({"type":"hello"})");
#pragma once

#include <skrobot/plugin_channels.hpp>

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <utility>

namespace skr::plugin {

// Whether this hub can serve WebSocket endpoints at all (ABI 1.8); it may still have no web port
// (the constructor below then fails with SKR_ERR_UNSUPPORTED).
inline bool hasWebEndpoints(const Host& host) noexcept {
  return host.api()->abi_minor >= 8 && host.api()->ws_serve != nullptr;
}

// Serves a path of the hub's web port until destroyed; then its connections close (1001) and no
// event follows.
class WebSocketEndpoint {
 public:
  struct Events {
    std::function<void(skr_ws_conn conn, const std::string& peer)> opened;
    std::function<void(skr_ws_conn conn, bool text, std::string_view data)> message;
    std::function<void(skr_ws_conn conn, const std::string& why)> closed;
  };

  WebSocketEndpoint() = default;
  // Throws Failure: SKR_ERR_UNSUPPORTED (an older hub, or no web port), SKR_ERR_INVALID_ARGUMENT
  // (a bad or taken path, a bad subprotocol).
  WebSocketEndpoint(Host& host, const std::string& path, const std::string& subprotocol,
                    std::size_t max_message_bytes, std::size_t max_queued_bytes, Events events)
      : state_(std::make_unique<State>(State{host, std::move(events)})) {
    detail::requireAbi(host, 8, host.api()->ws_serve != nullptr, "web endpoints");
    skr_ws_events ev{};
    ev.struct_size = sizeof ev;
    ev.opened = &opened;
    ev.message = &message;
    ev.closed = &closed;
    detail::check(
        host,
        host.api()->ws_serve(host.ctx(), path.c_str(), subprotocol.c_str(), max_message_bytes,
                             max_queued_bytes, &ev, state_.get(), &handle_),
        "ws_serve " + path);
  }
  WebSocketEndpoint(WebSocketEndpoint&& other) noexcept { swap(other); }
  WebSocketEndpoint& operator=(WebSocketEndpoint&& other) noexcept {
    WebSocketEndpoint(std::move(other)).swap(*this);
    return *this;
  }
  WebSocketEndpoint(const WebSocketEndpoint&) = delete;
  WebSocketEndpoint& operator=(const WebSocketEndpoint&) = delete;
  ~WebSocketEndpoint() { reset(); }

  void reset() noexcept {
    if (handle_ != 0) state_->host.api()->ws_unserve(state_->host.ctx(), handle_);
    handle_ = 0;
    state_.reset();
  }
  [[nodiscard]] bool active() const noexcept { return handle_ != 0; }

  // Queues a message (copied); false when the connection is gone. Beyond the endpoint's queue
  // bound the oldest droppable messages go first.
  bool send(skr_ws_conn conn, bool text, std::string_view data, bool droppable = true) noexcept {
    if (handle_ == 0) return false;
    return state_->host.api()->ws_send(state_->host.ctx(), conn, text ? 1 : 0, data.data(),
                                       data.size(), droppable ? 1 : 0) == SKR_OK;
  }
  // Closes a connection: code 1000 or 3000..4999; `closed` follows.
  bool close(skr_ws_conn conn, std::uint16_t code, const std::string& reason) noexcept {
    if (handle_ == 0) return false;
    return state_->host.api()->ws_close(state_->host.ctx(), conn, code, reason.c_str()) == SKR_OK;
  }

 private:
  struct State {
    Host host;
    Events events;
  };
  static void opened(void* user, skr_ws_conn conn, const char* peer) noexcept {
    auto* s = static_cast<State*>(user);
    if (!s->events.opened) return;
    detail::logged(s->host.api(), s->host.ctx(), "WebSocket opened",
                   [&] { s->events.opened(conn, peer != nullptr ? peer : ""); });
  }
  static void message(void* user, skr_ws_conn conn, int text, const void* data,
                      std::size_t size) noexcept {
    auto* s = static_cast<State*>(user);
    if (!s->events.message) return;
    detail::logged(s->host.api(), s->host.ctx(), "WebSocket message", [&] {
      s->events.message(conn, text != 0, std::string_view(static_cast<const char*>(data), size));
    });
  }
  static void closed(void* user, skr_ws_conn conn, const char* why) noexcept {
    auto* s = static_cast<State*>(user);
    if (!s->events.closed) return;
    detail::logged(s->host.api(), s->host.ctx(), "WebSocket closed",
                   [&] { s->events.closed(conn, why != nullptr ? why : ""); });
  }
  void swap(WebSocketEndpoint& other) noexcept {
    std::swap(state_, other.state_);
    std::swap(handle_, other.handle_);
  }

  std::unique_ptr<State> state_;
  skr_sub_handle handle_ = 0;
};

}  // namespace skr::plugin
