// SPDX-License-Identifier: Apache-2.0
// HTTP/1.1 heads, as far as a hub's web port and a ws: client need them: the request head's
// parser (pure: tests/fuzz/http_head_fuzz.cpp runs it on arbitrary bytes), the WebSocket
// handshake's checks and key, the responses (101 and errors), and upgrade(): a connection whose
// request asked for WebSocket becomes a WsTransport. Internal to the runtime's users (the hub's
// web port, the ws: dialer).
//
//   auto end = http::headEnd(bytes);        // 0 while incomplete; refuse past kMaxHeadBytes
//   auto request = http::parseRequest(bytes.substr(0, end));
//   if (auto bad = http::checkWebSocket(*request)) -> http::errorResponse(400, *bad)
//   auto ws = http::upgrade(loop, std::move(transport), *request, "skrobot-flow.v1",
//                           bytes.substr(end));
#pragma once

#include <skrobot/runtime/flow/transport.h>
#include <skrobot/runtime/result.h>

#include <cstddef>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace skr {
class Loop;
}

namespace skr::flow::http {

constexpr size_t kMaxHeadBytes = size_t{8} * 1024;  // a request or response head, CRLFs included
constexpr std::string_view kFlowSubprotocol = "skrobot-flow.v1";

// RFC 9110 token characters only, at least one (a method, a header name, a subprotocol).
[[nodiscard]] bool isToken(std::string_view s) noexcept;
// A URL path prefix of plain segments: '/' then segments of letters, digits, '_', '.', '-', '~'
// (not "." or ".."), no trailing '/' ("/teleop", "/ws"): the web port's mounts and endpoints.
[[nodiscard]] bool isPathPrefix(std::string_view s) noexcept;

// Where the head among `bytes` ends (just after its blank line), or 0 while it has not ended.
[[nodiscard]] size_t headEnd(std::string_view bytes) noexcept;

struct Request {
  std::string method;  // GET, HEAD or POST
  std::string target;  // as sent: "/flow", "/index.html?x=1"
  int minor = 1;       // HTTP/1.<minor>
  // Every header in order, names lower-cased, values without surrounding blanks.
  std::vector<std::pair<std::string, std::string>> headers;

  // A header's value (the first of that name), or nullopt. `name` lower-case.
  [[nodiscard]] std::optional<std::string_view> header(std::string_view name) const;
  // Every value of a comma-separated list header across its repeats, trimmed, empty ones skipped
  // ("Connection: keep-alive, Upgrade", "Sec-WebSocket-Protocol: a, b").
  [[nodiscard]] std::vector<std::string> list(std::string_view name) const;
  // Whether the list header holds `token`, case-insensitively.
  [[nodiscard]] bool hasToken(std::string_view name, std::string_view token) const;
  // The path part of the target (before '?').
  [[nodiscard]] std::string_view path() const noexcept;
};

// Parses a request head (headEnd()'s bytes). Errc::invalid_argument naming what is wrong: the
// reason for a 400 (or "method not allowed" for a 405, "head too large" for a 431).
[[nodiscard]] Result<Request> parseRequest(std::string_view head);

struct Response {
  int status = 0;
  std::string reason;
  std::vector<std::pair<std::string, std::string>> headers;  // names lower-cased
  [[nodiscard]] std::optional<std::string_view> header(std::string_view name) const;
  [[nodiscard]] bool hasToken(std::string_view name, std::string_view token) const;
};
// Parses a response head (a ws: client reading the server's answer).
[[nodiscard]] Result<Response> parseResponse(std::string_view head);

// The WebSocket upgrade a request asks for: nullopt when it is a valid one (GET, HTTP/1.1,
// Upgrade: websocket, Connection: Upgrade, Sec-WebSocket-Version: 13, a key of 16 bytes in
// base64), else why not.
[[nodiscard]] std::optional<std::string> checkWebSocket(const Request& request);
[[nodiscard]] bool wantsWebSocket(const Request& request);  // it asked (Upgrade: websocket)
// Sec-WebSocket-Accept for a key: base64(SHA-1(key + the RFC's GUID)).
[[nodiscard]] std::string websocketAccept(std::string_view key);

// The 101 that accepts an upgrade, naming `subprotocol` when not empty.
[[nodiscard]] std::string switchingProtocols(std::string_view key, std::string_view subprotocol);
// An error answer that closes the connection: status line, Content-Type text/plain, the body
// `text` and a newline. `status` among 400, 403, 404, 405, 426, 431, 500, 503.
[[nodiscard]] std::string errorResponse(int status, std::string_view text);

// The request a ws: client sends (GET `path`, Host `host`, the given key and subprotocol).
[[nodiscard]] std::string clientRequest(std::string_view host, std::string_view path,
                                        std::string_view key, std::string_view subprotocol);
// Checks the server's answer to clientRequest: nullopt when it accepted (101, the right Accept,
// the subprotocol named), else why not.
[[nodiscard]] std::optional<std::string> checkAccepted(const Response& response,
                                                       std::string_view key,
                                                       std::string_view subprotocol);

// Turns an accepted connection into a WebSocket server end: the 101 naming `subprotocol` is sent
// first, `already_read` (bytes that came after the request head) is read first, the peer's
// identity carries the request's Origin. Errc::invalid_argument (the reason for a 400) when the
// request is no valid upgrade or does not offer `subprotocol`. The transport is not started.
[[nodiscard]] Result<std::unique_ptr<transport::Transport>> upgrade(
    Loop& loop, std::unique_ptr<transport::Transport> below, const Request& request,
    std::string_view subprotocol, std::string_view already_read = {});

// A WebSocket server end of a module's subprotocol (upgradeMessages, plugin ABI 1.8): framing()
// is `messages`, and each message() is one whole WebSocket message, text or binary, of at most
// the size given (a longer one is refused on its frame header with close 1009, before any of it
// is kept). Text is not checked for UTF-8: the module parses what it takes.
class MessageTransport : public transport::Transport {
 public:
  // Whether the message being delivered (during Receiver::message()) is a text message.
  [[nodiscard]] virtual bool textMessage() const noexcept = 0;
  // One text or binary message; as write(), the bytes stay valid until written().
  [[nodiscard]] virtual Result<void> writeMessage(bool text, std::string_view data) = 0;
  // close() with this close code (RFC 6455 7.4; close() sends 1000) and reason.
  virtual void closeWith(uint16_t code, std::string_view reason) noexcept = 0;
};

// upgrade() for a subprotocol of whole messages of at most `max_message_bytes` (> 0) each.
[[nodiscard]] Result<std::unique_ptr<MessageTransport>> upgradeMessages(
    Loop& loop, std::unique_ptr<transport::Transport> below, const Request& request,
    std::string_view subprotocol, std::string_view already_read, uint64_t max_message_bytes);

}  // namespace skr::flow::http
