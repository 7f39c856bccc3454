// SPDX-License-Identifier: Apache-2.0
// The hub's web port (web_port.h): HTTP connections until a WebSocket upgrade, static files.
#include "web_port.h"

#include "endpoint.h"
#include "http_head.h"

#include <skrobot/runtime/flow/address.h>
#include <skrobot/runtime/log.h>

#include <arpa/inet.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <climits>
#include <cstring>
#include <vector>

namespace skr::flow {
namespace {

// Sent with every file: the page runs only its own scripts and is never framed by another site.
constexpr std::string_view kFileHeaders =
    "Content-Security-Policy: default-src 'self'; script-src 'self'; style-src 'self'; "
    "img-src 'self' data: blob:; connect-src 'self'; media-src 'self' blob:; worker-src 'self'; "
    "object-src 'none'; base-uri 'none'; frame-ancestors 'none'\r\n"
    "X-Content-Type-Options: nosniff\r\n"
    "Referrer-Policy: no-referrer\r\n"
    "Cache-Control: no-cache\r\n";

std::string lower(std::string_view s) {
  std::string out(s);
  std::transform(out.begin(), out.end(), out.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return out;
}

// The name of a Host header ("robot.local:8080" -> "robot.local", "[::1]:80" -> "::1").
std::string hostName(std::string_view host) {
  if (host.starts_with('[')) {
    const size_t end = host.find(']');
    return end == std::string_view::npos ? std::string() : lower(host.substr(1, end - 1));
  }
  return lower(host.substr(0, host.find(':')));
}

bool ipLiteral(const std::string& name) {
  unsigned char buf[16];
  return ::inet_pton(AF_INET, name.c_str(), buf) == 1 ||
         ::inet_pton(AF_INET6, name.c_str(), buf) == 1;
}

}  // namespace

// One connection while it speaks HTTP: the transport's receiver.
class WebPort::Conn final : public transport::Transport::Receiver,
                            public std::enable_shared_from_this<Conn> {
 public:
  Conn(WebPort& port, std::unique_ptr<transport::Transport> t)
      : port_(port), t_(std::move(t)), source_(t_->peer().source()) {}

  void start() {
    deadline_ = monotonicNs() + port_.head_timeout_ns_;
    if (auto r = t_->start(*this); !r) finish("cannot read: " + r.error().message);
  }

  // Past its deadline while waiting for a head.
  void sweep(Nanos now) {
    if (!serving_ && !closing_ && now >= deadline_) {
      ++port_.stats_.refused;
      log::debug(kLogSource, "FLOW-WEB", source_ + ": no request within the time allowed");
      finish("request head timeout");
    }
  }

  void closeNow(std::string_view why) {
    if (t_) t_->close(why);
  }

 private:
  std::span<char> readBuffer() override { return {buf_ + used_, sizeof buf_ - used_}; }

  void received(size_t n) override {
    used_ += n;
    if (!serving_) {
      next();
    } else if (used_ == sizeof buf_) {  // pipelined past a whole head while answering
      ++port_.stats_.refused;
      finish("too much sent ahead");
    }
  }

  void message(std::string_view) override {}

  void written(Result<void> result) override {
    if (!result) {
      finish("write failed");
      return;
    }
    if (closing_) {
      t_->close("answered");
      return;
    }
    if (file_ && file_->offset < file_->size) {
      port_.files_->next(std::move(*file_), weak_from_this(),
                         [this](Result<WebFile> f) { sendChunk(std::move(f)); });
      file_.reset();
      return;
    }
    // The answer is out: the next request (keep-alive).
    file_.reset();
    serving_ = false;
    deadline_ = monotonicNs() + port_.head_timeout_ns_;
    if (auto r = t_->resume(); !r) {
      finish("cannot read");
      return;
    }
    next();
  }

  void ended(const transport::TransportEnd&) override { finish("ended"); }

  void closed() noexcept override { port_.conns_.erase(this); }

  // Closes without answering.
  void finish(std::string_view why) {
    closing_ = true;
    if (t_) t_->close(why);
  }

  // An error answer; the connection closes once it is written.
  void refuse(int status, std::string_view why) {
    closing_ = true;
    serving_ = true;
    t_->pause();
    out_ = http::errorResponse(status, why);
    const std::string_view v = out_;
    if (auto r = t_->write({&v, 1}); !r) finish("write failed");
  }

  void refuseLogged(int status, uint64_t& counter, const std::string& why) {
    ++counter;
    log::info(kLogSource, "FLOW-WS-REFUSED", source_ + ": " + why);
    refuse(status, why);
  }

  // The head in buf_, if it has come.
  void next() {
    if (closing_) return;
    const std::string_view bytes(buf_, used_);
    const size_t end = http::headEnd(bytes);
    if (end == 0) {
      if (used_ > http::kMaxHeadBytes) {
        ++port_.stats_.refused;
        refuse(431, "request head too large");
      }
      return;
    }
    ++port_.stats_.requests;
    serving_ = true;
    t_->pause();
    auto request = http::parseRequest(bytes.substr(0, end));
    // What follows the head: the next request (kept), or a WebSocket's first frames.
    const std::string rest(bytes.substr(end));
    std::memmove(buf_, buf_ + end, used_ - end);
    used_ -= end;
    if (!request) {
      ++port_.stats_.refused;
      const std::string& why = request.error().message;
      refuse(why.find("method") != std::string::npos ? 405 : 400, why);
      return;
    }
    serve(*request, rest);
  }

  void serve(const http::Request& request, const std::string& rest) {
    const auto host_header = request.header("host");
    const std::string host = host_header ? hostName(*host_header) : std::string();
    if (!port_.hostAccepted(host)) {
      refuseLogged(403, port_.stats_.refused_host,
                   "Host \"" + std::string(host_header.value_or("")) +
                       "\" is not a name of this hub (server.web.hosts)");
      return;
    }
    const std::string path(request.path());
    if (path == "/flow" && port_.options_.flows) {
      upgrade(request, lower(*host_header), rest);
      return;
    }
    if (path == "/skrobot/token" && port_.options_.flows) {
      token(request, lower(*host_header));
      return;
    }
    if (const auto e = port_.endpoints_.find(path);
        e != port_.endpoints_.end() && http::wantsWebSocket(request)) {
      upgradeEndpoint(request, lower(*host_header), rest, e->second);
      return;
    }
    if (http::wantsWebSocket(request)) {
      refuseLogged(404, port_.stats_.refused,
                   "WebSocket on " + path + (path == "/flow" ? " (server.web.flows is off)" : ""));
      return;
    }
    if (request.method != "GET" && request.method != "HEAD") {
      ++port_.stats_.refused;
      refuse(405, request.method + " is not served here");
      return;
    }
    keep_alive_ = request.minor >= 1 && !request.hasToken("connection", "close");
    head_only_ = request.method == "HEAD";
    port_.files_->open(path, head_only_, weak_from_this(),
                       [this](Result<WebFile> f) { sendFirst(std::move(f)); });
  }

  // The checks of every WebSocket upgrade here: an allowed Origin, a valid request offering
  // `subprotocol`. False: refused (answered and counted).
  bool upgradeAllowed(const http::Request& request, const std::string& host,
                      std::string_view subprotocol) {
    if (const auto origin = request.header("origin");
        origin && !port_.originAllowed(lower(*origin), host)) {
      refuseLogged(403, port_.stats_.refused_origin,
                   "WebSocket from Origin \"" + std::string(*origin) +
                       "\", not allowed (server.web.origins)");
      return false;
    }
    if (auto bad = http::checkWebSocket(request)) {
      refuseLogged(400, port_.stats_.refused, "WebSocket upgrade: " + *bad);
      return false;
    }
    const std::vector<std::string> offered = request.list("sec-websocket-protocol");
    if (std::find(offered.begin(), offered.end(), subprotocol) == offered.end()) {
      refuseLogged(400, port_.stats_.refused,
                   "WebSocket on " + std::string(request.path()) + " without the subprotocol " +
                       std::string(subprotocol));
      return false;
    }
    return true;
  }

  // The transport is the WebSocket's now (or gone, when the upgrade failed): this HTTP
  // connection is over (freed by the next sweep, not under the caller's feet). Whether the
  // upgrade went through; a failure is counted and logged.
  template <typename T>
  bool handedOver(const Result<T>& ws) {
    closing_ = true;
    port_.finished_.push_back(shared_from_this());
    port_.conns_.erase(this);
    if (ws) return true;
    ++port_.stats_.refused;
    log::info(kLogSource, "FLOW-WS-REFUSED", source_ + ": " + ws.error().message);
    return false;
  }

  void upgrade(const http::Request& request, const std::string& host, const std::string& rest) {
    if (!upgradeAllowed(request, host, http::kFlowSubprotocol)) return;
    auto ws = http::upgrade(port_.loop_, std::move(t_), request, http::kFlowSubprotocol, rest);
    if (!handedOver(ws)) return;
    ++port_.stats_.upgrades;
    port_.flows_(std::move(ws).value());
  }

  void upgradeEndpoint(const http::Request& request, const std::string& host,
                       const std::string& rest, const Endpoint& e) {
    if (!upgradeAllowed(request, host, e.subprotocol)) return;
    auto ws = http::upgradeMessages(port_.loop_, std::move(t_), request, e.subprotocol, rest,
                                    e.max_message_bytes);
    if (!handedOver(ws)) return;
    ++port_.stats_.endpoint_upgrades;
    const auto accepted = e.accepted;  // the module may unserve the endpoint from inside
    accepted(std::move(ws).value());
  }

  void token(const http::Request& request, const std::string& host) {
    if (request.method != "POST") {
      ++port_.stats_.refused;
      refuse(405, "a page token is fetched with POST");
      return;
    }
    if (const auto origin = request.header("origin");
        origin && !port_.originAllowed(lower(*origin), host)) {
      refuseLogged(403, port_.stats_.refused_origin,
                   "page token for Origin \"" + std::string(*origin) +
                       "\", not allowed (server.web.origins)");
      return;
    }
    if (const auto site = request.header("sec-fetch-site"); site && *site != "same-origin") {
      refuseLogged(403, port_.stats_.refused,
                   "page token asked from a " + std::string(*site) + " page (Sec-Fetch-Site)");
      return;
    }
    if (const auto length = request.header("content-length");
        request.header("transfer-encoding") || (length && *length != "0")) {
      ++port_.stats_.refused;
      refuse(400, "a page token request has no body");
      return;
    }
    auto issued = port_.issue_token_(t_->peer().address);
    if (!issued) {
      ++port_.stats_.refused;
      refuse(issued.error().code == Errc::limit_exceeded ? 503 : 404, issued.error().message);
      return;
    }
    ++port_.stats_.tokens;
    const std::string body = "{\"token\":\"" + issued->token + "\",\"user\":\"" + issued->account +
                             "\",\"expires_in_ms\":" + std::to_string(issued->ttl_ns / kNsPerMs) +
                             "}";
    keep_alive_ = request.minor >= 1 && !request.hasToken("connection", "close");
    closing_ = !keep_alive_;
    out_ = "HTTP/1.1 200 OK\r\nContent-Type: application/json\r\nContent-Length: " +
           std::to_string(body.size()) +
           "\r\nCache-Control: no-store\r\nX-Content-Type-Options: nosniff\r\n"
           "Referrer-Policy: no-referrer\r\n" +
           (keep_alive_ ? "Connection: keep-alive\r\n\r\n" : "Connection: close\r\n\r\n") + body;
    const std::string_view v = out_;
    if (auto r = t_->write({&v, 1}); !r) finish("write failed");
  }

  void sendFirst(Result<WebFile> f) {
    if (!f) {
      if (f.error().code == Errc::not_found || f.error().code == Errc::invalid_argument) {
        ++port_.stats_.not_found;
        refuse(404, "not found");
      } else {
        log::warn(kLogSource, "FLOW-WEB", source_ + ": " + f.error().message);
        refuse(500, "cannot read the file");
      }
      return;
    }
    ++port_.stats_.files;
    out_ = "HTTP/1.1 200 OK\r\nContent-Type: " + f->content_type +
           "\r\nContent-Length: " + std::to_string(f->size) + "\r\n" + std::string(kFileHeaders) +
           (keep_alive_ ? "Connection: keep-alive\r\n\r\n" : "Connection: close\r\n\r\n");
    sendChunk(std::move(f), true);
  }

  void sendChunk(Result<WebFile> f, bool with_head = false) {
    if (!f) {
      log::warn(kLogSource, "FLOW-WEB", source_ + ": " + f.error().message);
      finish("read failed");
      return;
    }
    file_ = std::move(f).value();
    if (head_only_) file_->offset = file_->size;
    if (!keep_alive_ && file_->offset >= file_->size) closing_ = true;
    std::string_view views[2];
    size_t n = 0;
    if (with_head) views[n++] = out_;
    if (!file_->chunk.empty()) views[n++] = file_->chunk;
    if (n == 0) {
      written({});
      return;
    }
    if (auto r = t_->write({views, n}); !r) finish("write failed");
  }

  WebPort& port_;
  std::unique_ptr<transport::Transport> t_;
  std::string source_;
  char buf_[http::kMaxHeadBytes + 1];
  size_t used_ = 0;
  Nanos deadline_ = 0;
  bool serving_ = false;  // a request is being answered: reads paused
  bool closing_ = false;
  bool keep_alive_ = false;
  bool head_only_ = false;
  std::string out_;
  std::optional<WebFile> file_;
};

WebPort::WebPort(Loop& loop, const WebOptions& options, bool secure, uint32_t head_timeout_ms,
                 size_t max_connections, Upgraded flows, IssueToken issue_token,
                 std::unique_ptr<WebFiles> files)
    : loop_(loop),
      options_(options),
      secure_(secure),
      head_timeout_ns_(static_cast<Nanos>(head_timeout_ms) * kNsPerMs),
      max_connections_(max_connections),
      flows_(std::move(flows)),
      issue_token_(std::move(issue_token)),
      files_(std::move(files)),
      sweep_(loop, [this] { sweep(); }) {
  char name[HOST_NAME_MAX + 1] = {};
  if (::gethostname(name, sizeof name - 1) == 0 && name[0] != '\0') {
    const std::string n = lower(name);
    host_names_.insert(n);
    if (n.find('.') == std::string::npos) host_names_.insert(n + ".local");  // mDNS
  }
  for (const std::string& h : options_.hosts) host_names_.insert(h);
}

Result<std::unique_ptr<WebPort>> WebPort::open(Loop& loop, const WebOptions& options,
                                               const TlsContext* tls, uint32_t head_timeout_ms,
                                               size_t max_connections, Upgraded flows,
                                               IssueToken issue_token) {
  auto files = WebFiles::open(loop, options.root, options.mounts);
  if (!files) return files.error();
  auto port =
      std::make_unique<WebPort>(loop, options, tls != nullptr, head_timeout_ms, max_connections,
                                std::move(flows), std::move(issue_token), std::move(files).value());
  transport::ListenOptions lo;
  Address address{.kind = Address::Kind::tcp, .host = options.address, .port = options.port};
  if (tls != nullptr) {
    address.kind = Address::Kind::tls;
    lo.tls = *tls;
    lo.plain_peer_reply = http::errorResponse(400, "this port speaks HTTPS: use an https: address");
  }
  WebPort* self = port.get();
  auto l = transport::Listener::open(
      loop, address, std::move(lo),
      [self](std::unique_ptr<transport::Transport> t) { self->accepted(std::move(t)); });
  if (!l) return l.error();
  port->listener_ = std::move(l).value();
  port->sweep_.startEvery(100 * kNsPerMs);
  return port;
}

WebPort::~WebPort() {
  listener_.reset();
  sweep_.stop();
  // Closed at once (destroying a transport closes it): no callback reaches a Conn afterwards.
  conns_.clear();
  finished_.clear();
}

Result<void> WebPort::serve(const std::string& path, Endpoint endpoint) {
  if (!http::isPathPrefix(path)) {
    return makeError(Errc::invalid_argument,
                     "\"" + path + "\" is not a URL path of plain segments (\"/ws\")");
  }
  if (!http::isToken(endpoint.subprotocol)) {
    return makeError(Errc::invalid_argument,
                     "\"" + endpoint.subprotocol + "\" is not a subprotocol name (a token)");
  }
  if (endpoint.max_message_bytes == 0 || !endpoint.accepted) {
    return makeError(Errc::invalid_argument, "an endpoint needs a message size and a handler");
  }
  if (path == "/flow" || path == "/skrobot/token" || endpoints_.count(path) != 0) {
    return makeError(Errc::already_exists, path + " is served already on the web port");
  }
  endpoints_.emplace(path, std::move(endpoint));
  return {};
}

void WebPort::unserve(const std::string& path) noexcept {
  endpoints_.erase(path);
}

uint16_t WebPort::port() const noexcept {
  return listener_ ? listener_->port() : 0;
}

void WebPort::accepted(std::unique_ptr<transport::Transport> t) {
  if (conns_.size() >= max_connections_) {
    ++stats_.refused;
    log::warn(kLogSource, "FLOW-LIMIT",
              "web port: refusing " + t->peer().source() + ", " + std::to_string(conns_.size()) +
                  " HTTP connections already (server.max_connections)");
    return;  // destroying the transport closes it
  }
  auto c = std::make_shared<Conn>(*this, std::move(t));
  conns_.emplace(c.get(), c);
  c->start();
}

void WebPort::sweep() {
  finished_.clear();
  const Nanos now = monotonicNs();
  std::vector<std::shared_ptr<Conn>> all;
  all.reserve(conns_.size());
  for (auto& [p, c] : conns_) all.push_back(c);
  for (auto& c : all) c->sweep(now);
}

bool WebPort::hostAccepted(const std::string& host) const {
  if (host.empty()) return false;
  return ipLiteral(host) || host == "localhost" || host_names_.contains(host);
}

bool WebPort::originAllowed(const std::string& origin, const std::string& host) const {
  if (options_.origins.empty()) return origin == (secure_ ? "https://" : "http://") + host;
  return std::find(options_.origins.begin(), options_.origins.end(), origin) !=
         options_.origins.end();
}

}  // namespace skr::flow
