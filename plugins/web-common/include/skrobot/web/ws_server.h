// SPDX-License-Identifier: Apache-2.0
// The HTTP + WebSocket server of the web modules (websocket-ui, foxglove-bridge): libwebsockets
// on a thread of its own. A static library (skrobot_ws_server) linked into each module.
//
// Threads: start() and stop() on the owner's thread; send() and close() from any thread (they
// queue and wake the server thread with lws_cancel_service); the Events callbacks run on the
// server thread and must not block.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace skr::wsui {

struct WsServerOptions {
  std::string address = "127.0.0.1";  // the interface address to listen on
  int port = 8080;
  bool serve_files = true;  // false: no HTTP files (web_root unused), only the WebSocket
  std::string web_root;     // directory served over HTTP ("/" -> index.html)
  std::string tls_cert;     // PEM files; both set = HTTPS and WSS only
  std::string tls_key;
  std::string ws_path = "/ws";                    // the one WebSocket endpoint
  std::string subprotocol = "skrobot-avatar.v1";  // browsers must ask for it
  // true: a client that sends an Origin must come from a page of this server; false: any origin
  // (apps served elsewhere, e.g. Foxglove's web app)
  bool same_origin_only = true;
  std::string log_tag = "WSUI";              // log tags are <log_tag>-REFUSED and <log_tag>-LWS
  std::string peer_noun = "browser";         // in log lines: "<log_tag>-REFUSED browser 3: ..."
  std::size_t max_message_bytes = 1u << 20;  // one browser message, reassembled
  std::size_t max_queued_bytes = 8u << 20;   // per browser; oldest dropped beyond
  std::string content_security_policy =
      "default-src 'self'; script-src 'self'; style-src 'self'; img-src 'self' data: blob:; "
      "connect-src 'self'; media-src 'self' blob:; worker-src 'self'; object-src 'none'; "
      "base-uri 'none'; frame-ancestors 'none'";
};

struct WsServerEvents {
  std::function<void(std::uint64_t conn, const std::string& peer)> opened;
  // A complete message. Return an error text to refuse it: the connection is closed with that
  // reason (1003 for binary on a text-only message kind and the like, chosen by `close_code`).
  std::function<std::optional<std::string>(std::uint64_t conn, bool binary, std::string&& data,
                                           int& close_code)>
      message;
  std::function<void(std::uint64_t conn, const std::string& why)> closed;
  // A log line "<TAG> <text>" (<log_tag>-REFUSED, <log_tag>-LWS for libwebsockets' own, which
  // goes to the server started first when several run); 0 debug .. 3 error.
  std::function<void(int level, const std::string& line)> log;
};

struct WsServerStats {
  std::uint64_t connections = 0;         // open now
  std::uint64_t accepted = 0;            // since start
  std::uint64_t refused = 0;             // messages refused (connection closed)
  std::uint64_t refused_handshakes = 0;  // WebSocket upgrades refused (path, subprotocol, origin)
  std::uint64_t dropped = 0;             // outgoing messages dropped for slow browsers
};

class WsServer {
 public:
  WsServer();
  ~WsServer();  // stop()
  WsServer(const WsServer&) = delete;
  WsServer& operator=(const WsServer&) = delete;

  // Creates the context (binds the port) and starts the service thread. An error text on
  // failure (port in use, bad certificate, missing web root).
  std::optional<std::string> start(WsServerOptions options, WsServerEvents events);
  void stop() noexcept;

  // Queues a message for one browser, or for all when conn == 0. `droppable` messages are the
  // first to go when a browser's queue is full; others (speech audio) push the oldest droppable
  // ones out, and are dropped last.
  void send(std::uint64_t conn, bool binary, std::string data, bool droppable = true);
  // Closes a browser's connection with a WebSocket close code and reason.
  void close(std::uint64_t conn, int code, const std::string& reason);

  [[nodiscard]] WsServerStats stats() const;
  [[nodiscard]] int port() const noexcept;

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace skr::wsui
