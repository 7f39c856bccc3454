// SPDX-License-Identifier: Apache-2.0
#include "http_head.h"

#include "ws_transport.h"

#include <skrobot/base64.hpp>

#include <openssl/sha.h>

#include <algorithm>

namespace skr::flow::http {
namespace {

constexpr std::string_view kWebSocketGuid = "258EAFA5-E914-47DA-95CA-C5AB0DC85B11";

char lower(char c) noexcept {
  return c >= 'A' && c <= 'Z' ? static_cast<char>(c - 'A' + 'a') : c;
}

bool equalsNoCase(std::string_view a, std::string_view b) noexcept {
  return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin(),
                                            [](char x, char y) { return lower(x) == lower(y); });
}

std::string_view trim(std::string_view s) noexcept {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
  return s;
}

using Headers = std::vector<std::pair<std::string, std::string>>;

// The header lines after the start line: "name: value" CRLF ..., then the blank line.
Result<void> parseHeaders(std::string_view rest, Headers& out) {
  while (true) {
    const size_t eol = rest.find("\r\n");
    if (eol == std::string_view::npos)
      return makeError(Errc::invalid_argument, "a head without its blank line");
    const std::string_view line = rest.substr(0, eol);
    rest.remove_prefix(eol + 2);
    if (line.empty()) break;
    if (line.front() == ' ' || line.front() == '\t') {
      return makeError(Errc::invalid_argument, "a folded header line");
    }
    const size_t colon = line.find(':');
    if (colon == std::string_view::npos)
      return makeError(Errc::invalid_argument, "a header line without ':'");
    const std::string_view name = line.substr(0, colon);
    if (!isToken(name)) return makeError(Errc::invalid_argument, "a bad header name");
    const std::string_view value = trim(line.substr(colon + 1));
    if (std::any_of(value.begin(), value.end(), [](char c) {
          return (static_cast<unsigned char>(c) < 0x20 && c != '\t') || c == 0x7F;
        })) {
      return makeError(Errc::invalid_argument, "a control character in a header value");
    }
    std::string n(name);
    std::transform(n.begin(), n.end(), n.begin(), lower);
    out.emplace_back(std::move(n), std::string(value));
    if (out.size() > 100) return makeError(Errc::invalid_argument, "more than 100 header lines");
  }
  if (!rest.empty()) return makeError(Errc::invalid_argument, "bytes after the head's blank line");
  return {};
}

std::optional<std::string_view> find(const Headers& headers, std::string_view name) {
  for (const auto& [n, v] : headers) {
    if (n == name) return std::string_view(v);
  }
  return std::nullopt;
}

std::vector<std::string> listOf(const Headers& headers, std::string_view name) {
  std::vector<std::string> out;
  for (const auto& [n, v] : headers) {
    if (n != name) continue;
    std::string_view rest = v;
    while (!rest.empty()) {
      const size_t comma = rest.find(',');
      const std::string_view item = trim(rest.substr(0, comma));
      if (!item.empty()) out.emplace_back(item);
      if (comma == std::string_view::npos) break;
      rest.remove_prefix(comma + 1);
    }
  }
  return out;
}

bool tokenIn(const Headers& headers, std::string_view name, std::string_view token) {
  const auto items = listOf(headers, name);
  return std::any_of(items.begin(), items.end(),
                     [&](const std::string& i) { return equalsNoCase(i, token); });
}

std::string_view statusText(int status) noexcept {
  switch (status) {
    case 400:
      return "Bad Request";
    case 403:
      return "Forbidden";
    case 404:
      return "Not Found";
    case 405:
      return "Method Not Allowed";
    case 426:
      return "Upgrade Required";
    case 431:
      return "Request Header Fields Too Large";
    case 503:
      return "Service Unavailable";
    default:
      return "Internal Server Error";
  }
}

}  // namespace

bool isToken(std::string_view s) noexcept {
  if (s.empty()) return false;
  return std::all_of(s.begin(), s.end(), [](char c) {
    return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') ||
           std::string_view("!#$%&'*+-.^_`|~").find(c) != std::string_view::npos;
  });
}

bool isPathPrefix(std::string_view s) noexcept {
  if (s.size() < 2 || s.front() != '/' || s.back() == '/') return false;
  size_t start = 1;
  while (start <= s.size()) {
    const size_t end = std::min(s.find('/', start), s.size());
    const std::string_view seg = s.substr(start, end - start);
    const bool plain = std::all_of(seg.begin(), seg.end(), [](char c) {
      return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
             c == '_' || c == '.' || c == '-' || c == '~';
    });
    if (seg.empty() || seg == "." || seg == ".." || !plain) return false;
    start = end + 1;
  }
  return true;
}

size_t headEnd(std::string_view bytes) noexcept {
  const size_t at = bytes.find("\r\n\r\n");
  return at == std::string_view::npos ? 0 : at + 4;
}

std::optional<std::string_view> Request::header(std::string_view name) const {
  return find(headers, name);
}
std::vector<std::string> Request::list(std::string_view name) const {
  return listOf(headers, name);
}
bool Request::hasToken(std::string_view name, std::string_view token) const {
  return tokenIn(headers, name, token);
}
std::string_view Request::path() const noexcept {
  const std::string_view t = target;
  return t.substr(0, t.find('?'));
}

std::optional<std::string_view> Response::header(std::string_view name) const {
  return find(headers, name);
}
bool Response::hasToken(std::string_view name, std::string_view token) const {
  return tokenIn(headers, name, token);
}

Result<Request> parseRequest(std::string_view head) {
  if (head.size() > kMaxHeadBytes) return makeError(Errc::invalid_argument, "head too large");
  const size_t eol = head.find("\r\n");
  if (eol == std::string_view::npos) return makeError(Errc::invalid_argument, "no request line");
  const std::string_view line = head.substr(0, eol);
  const size_t sp1 = line.find(' ');
  const size_t sp2 = sp1 == std::string_view::npos ? sp1 : line.find(' ', sp1 + 1);
  if (sp2 == std::string_view::npos || line.find(' ', sp2 + 1) != std::string_view::npos) {
    return makeError(Errc::invalid_argument, "a request line that is not METHOD TARGET VERSION");
  }
  Request r;
  r.method = std::string(line.substr(0, sp1));
  r.target = std::string(line.substr(sp1 + 1, sp2 - sp1 - 1));
  const std::string_view version = line.substr(sp2 + 1);
  if (!isToken(r.method)) return makeError(Errc::invalid_argument, "a bad method");
  if (r.target.empty() || r.target.front() != '/' ||
      std::any_of(r.target.begin(), r.target.end(),
                  [](char c) { return static_cast<unsigned char>(c) <= 0x20 || c == 0x7F; })) {
    return makeError(Errc::invalid_argument, "a target that is not an absolute path");
  }
  if (version != "HTTP/1.1" && version != "HTTP/1.0") {
    return makeError(Errc::invalid_argument, "not HTTP/1.1");
  }
  r.minor = version.back() - '0';
  if (auto h = parseHeaders(head.substr(eol + 2), r.headers); !h) return h.error();
  if (r.method != "GET" && r.method != "HEAD" && r.method != "POST") {
    return makeError(Errc::invalid_argument, "method not allowed");
  }
  return r;
}

Result<Response> parseResponse(std::string_view head) {
  if (head.size() > kMaxHeadBytes) return makeError(Errc::invalid_argument, "head too large");
  const size_t eol = head.find("\r\n");
  if (eol == std::string_view::npos) return makeError(Errc::invalid_argument, "no status line");
  const std::string_view line = head.substr(0, eol);
  if (!line.starts_with("HTTP/1.1 ") && !line.starts_with("HTTP/1.0 ")) {
    return makeError(Errc::invalid_argument, "not an HTTP/1.1 answer");
  }
  Response r;
  const std::string_view code = line.substr(9, 3);
  if (code.size() != 3 ||
      !std::all_of(code.begin(), code.end(), [](char c) { return c >= '0' && c <= '9'; }) ||
      (line.size() > 12 && line[12] != ' ')) {
    return makeError(Errc::invalid_argument, "a bad status line");
  }
  r.status = (code[0] - '0') * 100 + (code[1] - '0') * 10 + (code[2] - '0');
  if (line.size() > 13) r.reason = std::string(line.substr(13));
  if (auto h = parseHeaders(head.substr(eol + 2), r.headers); !h) return h.error();
  return r;
}

bool wantsWebSocket(const Request& request) {
  return request.hasToken("upgrade", "websocket");
}

std::optional<std::string> checkWebSocket(const Request& request) {
  if (request.method != "GET") return "a WebSocket upgrade is a GET";
  if (request.minor != 1) return "a WebSocket upgrade needs HTTP/1.1";
  if (!wantsWebSocket(request)) return "no Upgrade: websocket";
  if (!request.hasToken("connection", "upgrade")) return "no Connection: Upgrade";
  const auto version = request.header("sec-websocket-version");
  if (!version || *version != "13") return "Sec-WebSocket-Version is not 13";
  const auto key = request.header("sec-websocket-key");
  const auto raw = key ? base64::decode(*key) : std::nullopt;
  if (!raw || raw->size() != 16) return "Sec-WebSocket-Key is not 16 bytes in base64";
  return std::nullopt;
}

std::string websocketAccept(std::string_view key) {
  std::string text(key);
  text.append(kWebSocketGuid);
  unsigned char digest[SHA_DIGEST_LENGTH];
  SHA1(reinterpret_cast<const unsigned char*>(text.data()), text.size(), digest);
  return base64::encode({reinterpret_cast<const char*>(digest), sizeof digest});
}

std::string switchingProtocols(std::string_view key, std::string_view subprotocol) {
  std::string r =
      "HTTP/1.1 101 Switching Protocols\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
      "Sec-WebSocket-Accept: " +
      websocketAccept(key) + "\r\n";
  if (!subprotocol.empty()) r += "Sec-WebSocket-Protocol: " + std::string(subprotocol) + "\r\n";
  return r + "\r\n";
}

std::string errorResponse(int status, std::string_view text) {
  const std::string body = std::string(text) + "\n";
  return "HTTP/1.1 " + std::to_string(status) + " " + std::string(statusText(status)) +
         "\r\nContent-Type: text/plain; charset=utf-8\r\nContent-Length: " +
         std::to_string(body.size()) +
         "\r\nX-Content-Type-Options: nosniff\r\nCache-Control: no-store\r\nConnection: "
         "close\r\n\r\n" +
         body;
}

std::string clientRequest(std::string_view host, std::string_view path, std::string_view key,
                          std::string_view subprotocol) {
  std::string r =
      "GET " + std::string(path) + " HTTP/1.1\r\nHost: " + std::string(host) +
      "\r\nUpgrade: websocket\r\nConnection: Upgrade\r\nSec-WebSocket-Key: " + std::string(key) +
      "\r\nSec-WebSocket-Version: 13\r\n";
  if (!subprotocol.empty()) r += "Sec-WebSocket-Protocol: " + std::string(subprotocol) + "\r\n";
  return r + "\r\n";
}

std::optional<std::string> checkAccepted(const Response& response, std::string_view key,
                                         std::string_view subprotocol) {
  if (response.status != 101) {
    return "the server answered " + std::to_string(response.status) + " " + response.reason +
           " instead of 101 Switching Protocols";
  }
  if (!response.hasToken("upgrade", "websocket") || !response.hasToken("connection", "upgrade")) {
    return "the 101 lacks Upgrade: websocket or Connection: Upgrade";
  }
  const auto accept = response.header("sec-websocket-accept");
  if (!accept || *accept != websocketAccept(key)) return "a wrong Sec-WebSocket-Accept";
  const auto protocol = response.header("sec-websocket-protocol");
  if (!subprotocol.empty() && (!protocol || *protocol != subprotocol)) {
    return "the server did not agree to the subprotocol " + std::string(subprotocol);
  }
  return std::nullopt;
}

namespace {

Result<std::unique_ptr<transport::WsTransport>> serverEnd(
    Loop& loop, std::unique_ptr<transport::Transport> below, const Request& request,
    std::string_view subprotocol, std::string_view already_read, uint64_t max_message_bytes) {
  if (auto bad = checkWebSocket(request)) return makeError(Errc::invalid_argument, *bad);
  const auto offered = request.list("sec-websocket-protocol");  // tokens: case-sensitive
  if (!subprotocol.empty() &&
      std::find(offered.begin(), offered.end(), subprotocol) == offered.end()) {
    return makeError(Errc::invalid_argument,
                     "the client does not offer the subprotocol " + std::string(subprotocol));
  }
  return std::make_unique<transport::WsTransport>(
      loop, std::move(below), true, std::string(request.header("origin").value_or("")),
      switchingProtocols(*request.header("sec-websocket-key"), subprotocol),
      std::string(already_read), max_message_bytes);
}

}  // namespace

Result<std::unique_ptr<transport::Transport>> upgrade(Loop& loop,
                                                      std::unique_ptr<transport::Transport> below,
                                                      const Request& request,
                                                      std::string_view subprotocol,
                                                      std::string_view already_read) {
  auto ws = serverEnd(loop, std::move(below), request, subprotocol, already_read, 0);
  if (!ws) return ws.error();
  return std::unique_ptr<transport::Transport>(std::move(ws).value());
}

Result<std::unique_ptr<MessageTransport>> upgradeMessages(
    Loop& loop, std::unique_ptr<transport::Transport> below, const Request& request,
    std::string_view subprotocol, std::string_view already_read, uint64_t max_message_bytes) {
  if (max_message_bytes == 0) return makeError(Errc::invalid_argument, "no message size limit");
  auto ws =
      serverEnd(loop, std::move(below), request, subprotocol, already_read, max_message_bytes);
  if (!ws) return ws.error();
  return std::unique_ptr<MessageTransport>(std::move(ws).value());
}

}  // namespace skr::flow::http
