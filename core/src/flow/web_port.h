// SPDX-License-Identifier: Apache-2.0
// server.web: the hub's web port (docs/security.md, "The web port"). A Listener (tcp:, or tls:
// when server.tls is set: HTTPS and WSS only) whose connections speak HTTP/1.1 until one asks for
// a WebSocket. Each reads a request head (http_head.h, at most http::kMaxHeadBytes, within
// `head_timeout_ms` of the connection or of the previous answer), then:
//   - its Host must be an IP literal, "localhost", this machine's name or one of
//     server.web.hosts (DNS rebinding), else 403;
//   - GET /flow, when server.web.flows: a WebSocket upgrade offering skrobot-flow.v1, from an
//     allowed Origin (or none), becomes a WsTransport handed to `flows` (the FlowServer's
//     accept); else 403 (Origin), 400 (no such subprotocol, a bad upgrade) or 404 (flows off);
//   - GET of a module's endpoint (serve(), plugin ABI 1.8): a WebSocket upgrade offering its
//     subprotocol, from an allowed Origin (or none), becomes an http::MessageTransport of whole
//     messages handed to the endpoint; else 403 (Origin) or 400 (no such subprotocol, a bad
//     upgrade);
//   - POST /skrobot/token, when server.web.flows: a page token (page_tokens.h) for the peer's
//     address as {"token", "user", "expires_in_ms"}, Cache-Control: no-store and no CORS header
//     (a foreign page cannot read it); refused 403 for a foreign Origin or a Sec-Fetch-Site other
//     than same-origin, 503 when throttled;
//   - GET and HEAD of anything else are files (web_files.h), read on libuv's thread pool; other
//     methods 405.
// Refusals of Host, Origin and upgrades are logged FLOW-WS-REFUSED and counted (stats(), in
// hub.stats "web"). At most `max_connections` speak HTTP at once: more are closed at once
// (FLOW-LIMIT). Errors close the connection; a file keeps it open (HTTP/1.1 keep-alive, one
// request at a time). Main loop thread only.
#pragma once

#include "families/session/page_tokens.h"
#include "http_head.h"
#include "web_files.h"

#include <skrobot/hub/flow/hub_stats.h>
#include <skrobot/hub/flow/server.h>
#include <skrobot/runtime/flow/tls.h>
#include <skrobot/runtime/flow/transport.h>
#include <skrobot/runtime/loop.h>
#include <skrobot/runtime/loop_handles.h>
#include <skrobot/runtime/result.h>

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <unordered_map>
#include <vector>

namespace skr::flow {

class WebPort {
 public:
  using Upgraded = std::function<void(std::unique_ptr<transport::Transport>)>;
  using IssueToken = std::function<Result<PageTokens::Issued>(const std::string& address)>;

  // Opens the files' directories and listens. `tls` set: every connection is a TLS session on
  // it. Errors name the address or the directory.
  [[nodiscard]] static Result<std::unique_ptr<WebPort>> open(Loop& loop, const WebOptions& options,
                                                             const TlsContext* tls,
                                                             uint32_t head_timeout_ms,
                                                             size_t max_connections, Upgraded flows,
                                                             IssueToken issue_token);
  ~WebPort();  // stops listening and closes the connections still speaking HTTP
  WebPort(const WebPort&) = delete;
  WebPort& operator=(const WebPort&) = delete;
  WebPort(WebPort&&) = delete;
  WebPort& operator=(WebPort&&) = delete;

  // A module's WebSocket endpoint (plugin ABI 1.8): whole messages of at most max_message_bytes.
  struct Endpoint {
    std::string subprotocol;  // an RFC 9110 token the client must offer
    uint64_t max_message_bytes = 0;
    std::function<void(std::unique_ptr<http::MessageTransport>)> accepted;
  };
  // Serves `path` (http::isPathPrefix) with `endpoint`. Errc::invalid_argument for a bad path or
  // subprotocol, Errc::already_exists for /flow, /skrobot/token or a path served already.
  [[nodiscard]] Result<void> serve(const std::string& path, Endpoint endpoint);
  void unserve(const std::string& path) noexcept;

  [[nodiscard]] uint16_t port() const noexcept;  // the bound port (useful with port 0)
  [[nodiscard]] const WebCounters& stats() const noexcept { return stats_; }
  [[nodiscard]] bool secure() const noexcept { return secure_; }

  class Conn;
  WebPort(Loop& loop, const WebOptions& options, bool secure, uint32_t head_timeout_ms,
          size_t max_connections, Upgraded flows, IssueToken issue_token,
          std::unique_ptr<WebFiles> files);

 private:
  friend class Conn;
  void accepted(std::unique_ptr<transport::Transport> t);
  void sweep();
  // Whether a Host header's name (without its port, lower-cased) may be served.
  [[nodiscard]] bool hostAccepted(const std::string& host) const;
  // Whether a page of `origin` may open /flow when the request named `host`.
  [[nodiscard]] bool originAllowed(const std::string& origin, const std::string& host) const;

  Loop& loop_;
  WebOptions options_;
  bool secure_;
  Nanos head_timeout_ns_;
  size_t max_connections_;  // HTTP connections at once (server.max_connections); more are closed
  Upgraded flows_;
  IssueToken issue_token_;
  std::unique_ptr<WebFiles> files_;
  std::unique_ptr<transport::Listener> listener_;
  std::set<std::string> host_names_;           // this machine's names and server.web.hosts
  std::map<std::string, Endpoint> endpoints_;  // modules' WebSocket endpoints, by path
  std::unordered_map<Conn*, std::shared_ptr<Conn>> conns_;
  std::vector<std::shared_ptr<Conn>> finished_;  // upgraded: freed by the next sweep
  Timer sweep_;
  WebCounters stats_;
};

}  // namespace skr::flow
