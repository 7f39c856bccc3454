// The HTTP + WebSocket server of websocket-ui: libwebsockets on a thread of its own.
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
  std::string web_root;  // directory served over HTTP ("/" -> index.html)
  std::string tls_cert;  // PEM files; both set = HTTPS and WSS only
  std::string tls_key;
  std::string ws_path = "/ws";                    // the one WebSocket endpoint
  std::string subprotocol = "skrobot-avatar.v1";  // browsers must ask for it
  std::size_t max_message_bytes = 1u << 20;       // one browser message, reassembled
  std::size_t max_queued_bytes = 8u << 20;        // per browser; oldest dropped beyond
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
  // A log line "<TAG> <text>" (WSUI-REFUSED, WSUI-LWS for libwebsockets' own); 0 debug .. 3 error.
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
