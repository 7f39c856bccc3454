// SPDX-License-Identifier: Apache-2.0
// Where websocket-ui's browsers connect (docs/websocket-ui.md): an endpoint on the hub's web port
// (plugin ABI 1.8; the default, with no `port` in the module's config), or the module's own
// libwebsockets server on `port` (skrobot/web/ws_server.h). One face for both: the module sends,
// closes and counts the same way. Events come on the hub's loop thread from the web port, on the
// server's thread from its own server; either way the module hands them to the loop (post).
#pragma once

#include <skrobot/web/ws_server.h>
#include <skrobot/plugin_web.hpp>

#include <cstdint>
#include <optional>
#include <set>
#include <string>

namespace skr::wsui {

class Browsers {
 public:
  // Its own server on options.port: an error text when it cannot listen.
  std::optional<std::string> startOwn(const WsServerOptions& options, WsServerEvents events);
  // options.ws_path with options.subprotocol on the hub's web port. Throws plugin::Failure
  // (SKR_ERR_UNSUPPORTED: the hub has no web port).
  void startOnHub(skr::plugin::Host& host, const WsServerOptions& options, WsServerEvents events);
  void stop() noexcept;  // no event after it returns

  // As WsServer::send and WsServer::close (conn 0: every browser, for send).
  void send(std::uint64_t conn, bool binary, std::string data, bool droppable = true);
  void close(std::uint64_t conn, int code, const std::string& reason);

  [[nodiscard]] WsServerStats stats() const;
  [[nodiscard]] bool onHub() const noexcept { return endpoint_.active(); }
  [[nodiscard]] int port() const noexcept { return server_.port(); }  // its own server's

 private:
  WsServer server_;
  skr::plugin::WebSocketEndpoint endpoint_;
  // The web port's connections (loop thread): for send to all, and the counts.
  std::set<std::uint64_t> conns_;
  WsServerStats hub_stats_;
};

}  // namespace skr::wsui
