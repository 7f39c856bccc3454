// SPDX-License-Identifier: Apache-2.0
// The hub's UDP port (udp_port.h): one socket, stateless cookies, sessions as Transports.
#include "udp_port.h"

#include <skrobot/runtime/clock.h>
#include <skrobot/runtime/loop_handles.h>

#include "message_session.h"

#include <arpa/inet.h>
#include <netdb.h>
#include <netinet/in.h>
#include <sodium.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <map>
#include <optional>
#include <unordered_map>

namespace skr::flow {
namespace {

using transport::PeerIdentity;
using transport::Transport;
using transport::TransportEnd;
using transport::TransportKind;

// Frames a paused session may have waiting (a board sends one request at a time).
constexpr size_t kPendingBytes = 64u << 10;
// Datagrams read per readiness event, so that a flood does not hold the loop.
constexpr int kReadsPerWake = 256;
constexpr Nanos kMinute = 60 * kNsPerSec;

// A peer's address as the hub writes it into a cookie (family, address bytes, port) and as text.
struct Peer {
  sockaddr_storage addr{};
  socklen_t len = 0;

  [[nodiscard]] std::string bytes() const {
    std::string out(1, static_cast<char>(addr.ss_family));
    if (addr.ss_family == AF_INET) {
      const auto* a = reinterpret_cast<const sockaddr_in*>(&addr);
      out.append(reinterpret_cast<const char*>(&a->sin_addr), 4);
      out.append(reinterpret_cast<const char*>(&a->sin_port), 2);
    } else if (addr.ss_family == AF_INET6) {
      const auto* a = reinterpret_cast<const sockaddr_in6*>(&addr);
      out.append(reinterpret_cast<const char*>(&a->sin6_addr), 16);
      out.append(reinterpret_cast<const char*>(&a->sin6_port), 2);
    }
    return out;
  }
  [[nodiscard]] std::string text() const {
    char host[INET6_ADDRSTRLEN] = "?";
    uint16_t port = 0;
    if (addr.ss_family == AF_INET) {
      const auto* a = reinterpret_cast<const sockaddr_in*>(&addr);
      ::inet_ntop(AF_INET, &a->sin_addr, host, sizeof host);
      port = ntohs(a->sin_port);
      return std::string(host) + ":" + std::to_string(port);
    }
    const auto* a = reinterpret_cast<const sockaddr_in6*>(&addr);
    ::inet_ntop(AF_INET6, &a->sin6_addr, host, sizeof host);
    port = ntohs(a->sin6_port);
    return "[" + std::string(host) + "]:" + std::to_string(port);
  }
};

class Port;

// One board's session (message_session.h): one frame per datagram; its carrier is the port.
class Session final : public transport::MessageSession {
 public:
  Session(Loop& loop, Port* port, PeerIdentity peer, uint32_t max_frame)
      : MessageSession(loop, TransportKind::udp, std::move(peer), max_frame, kPendingBytes,
                       "the UDP session ended"),
        port_(port) {}
  ~Session() override { leave(); }

  // From the port.
  void frame(std::string_view bytes, transport::UdpStats& stats) {
    if (!received(bytes)) ++stats.overrun;  // a board that does not wait for its answers
  }

  // The port's bookkeeping of the session.
  uint32_t id = 0;
  Peer where;
  udp::Key key{};  // the session key
  udp::Nonce client_nonce{};
  std::string user;
  std::string accept;  // the ACCEPT sent, sent again for a repeated OPEN
  uint32_t seq_out = 0;
  udp::ReplayWindow window;
  Nanos last_in = 0;

 private:
  // UDP drops, never waits: every frame is taken.
  bool sendFrame(std::string_view frame) override;
  void leaveCarrier() noexcept override;

  Port* port_;  // while attached()
};

class Port final : public UdpPort {
 public:
  Port(Loop& loop, transport::UdpOptions options, int fd, KeyOf key_of, Accepted accepted)
      : loop_(loop),
        options_(std::move(options)),
        fd_(fd),
        key_of_(std::move(key_of)),
        accepted_(std::move(accepted)),
        sweep_(loop, [this] { sweep(); }) {
    randombytes_buf(secret_.data(), secret_.size());
  }
  ~Port() override {
    std::vector<Session*> all;
    for (auto& [id, s] : sessions_) all.push_back(s);
    for (Session* s : all) end(s, {TransportEnd::Why::error, "UDP port closed"}, true);
    watch_.stop();
    watch_ = {};
    ::close(fd_);
  }

  Result<void> start() {
    auto w = FdWatch::open(loop_, fd_, [this](unsigned events) { onEvents(events); });
    if (!w) return w.error();
    watch_ = std::move(w).value();
    watch_.watch(FdWatch::readable);
    const Nanos every = std::clamp<Nanos>(
        static_cast<Nanos>(options_.session_timeout_ms) * kNsPerMs / 4, 10 * kNsPerMs, kNsPerSec);
    sweep_.startEvery(every);
    sockaddr_storage a{};
    socklen_t len = sizeof a;
    if (::getsockname(fd_, reinterpret_cast<sockaddr*>(&a), &len) == 0) {
      port_ = ntohs(a.ss_family == AF_INET ? reinterpret_cast<sockaddr_in*>(&a)->sin_port
                                           : reinterpret_cast<sockaddr_in6*>(&a)->sin6_port);
    }
    return {};
  }

  [[nodiscard]] uint16_t port() const noexcept override { return port_; }
  [[nodiscard]] const transport::UdpStats& stats() const noexcept override { return stats_; }
  [[nodiscard]] size_t sessions() const noexcept override { return sessions_.size(); }

  // A session's frame as one DATA datagram.
  void sendFrame(Session& s, std::string_view frame) {
    if (frame.size() + udp::kDataOverhead > options_.max_datagram) {
      ++stats_.too_large;  // SESSION_LIMITS keeps them away from a board that states its limit
      return;
    }
    sendTo(s.where, udp::makeNumbered(udp::Type::data, s.key, s.id, ++s.seq_out, frame));
  }
  // The session's transport closes: the board is told, the session forgotten.
  void leave(Session* s) noexcept { end(s, {}, true); }

 private:
  void onEvents(unsigned events) {
    if ((events & FdWatch::readable) != 0) read();
  }

  void read() {
    std::string buf(options_.max_datagram + 1, '\0');
    for (int i = 0; i < kReadsPerWake; ++i) {
      Peer from;
      from.len = sizeof from.addr;
      const ssize_t n = ::recvfrom(fd_, buf.data(), buf.size(), 0,
                                   reinterpret_cast<sockaddr*>(&from.addr), &from.len);
      if (n < 0 && errno == EINTR) continue;
      if (n < 0) break;  // EAGAIN; an ICMP error for an earlier datagram: nothing to do
      ++stats_.datagrams_in;
      stats_.bytes_in += static_cast<uint64_t>(n);
      if (static_cast<size_t>(n) > options_.max_datagram) {
        ++stats_.malformed;  // larger than this port takes
        continue;
      }
      datagram(std::string_view(buf.data(), static_cast<size_t>(n)), from);
    }
  }

  void datagram(std::string_view d, const Peer& from) {
    const auto type = udp::typeOf(d);
    if (!type) {
      ++stats_.malformed;
      return;
    }
    switch (*type) {
      case udp::Type::hello:
        return hello(d, from);
      case udp::Type::open:
        return open(d, from);
      case udp::Type::data:
      case udp::Type::close:
        return numbered(d, from);
      default:
        ++stats_.malformed;  // COOKIE and ACCEPT go the other way
        return;
    }
  }

  [[nodiscard]] uint64_t minute() const noexcept {
    return static_cast<uint64_t>(monotonicNs() / kMinute);
  }

  // No state kept, and the answer (26 bytes) is never larger than the HELLO (64 at least).
  void hello(std::string_view d, const Peer& from) {
    if (d.size() < udp::kHelloBytes) {
      ++stats_.short_hello;
      return;
    }
    const auto h = udp::parseHello(d);
    if (!h) {
      ++stats_.malformed;
      return;
    }
    const udp::Key c = udp::cookie(secret_, from.bytes(), h->user, h->nonce, minute());
    ++stats_.cookies_sent;
    sendTo(from, udp::makeCookie(h->nonce, c));
  }

  void open(std::string_view d, const Peer& from) {
    const auto o = udp::parseOpen(d);
    if (!o) {
      ++stats_.malformed;
      return;
    }
    const std::string peer = from.bytes();
    const uint64_t now = minute();
    bool cookie_ok = false;
    for (uint64_t m : {now, now - 1}) {
      const udp::Key c = udp::cookie(secret_, peer, o->user, o->nonce, m);
      cookie_ok = cookie_ok || udp::sameMac(c.data(), o->cookie.data(), c.size());
    }
    if (!cookie_ok) {
      ++stats_.bad_cookie;
      return;
    }
    const std::optional<udp::Key> key = key_of_(o->user);
    const udp::Key mac = key ? udp::mac128(*key, o->signed_part) : udp::Key{};
    if (!key || !udp::sameMac(mac.data(), o->mac.data(), mac.size())) {
      ++stats_.bad_mac;
      return;
    }
    // The same OPEN again (its ACCEPT was lost): the same answer while its session lives; after
    // that, a replay (its cookie still holds). A new one from the same board and account (it
    // restarted): the old session ends.
    for (auto& [id, s] : sessions_) {
      if (s->user == o->user && s->where.bytes() == peer && s->client_nonce == o->nonce) {
        sendTo(from, s->accept);
        return;
      }
    }
    std::string tag(o->user);
    tag.append(reinterpret_cast<const char*>(o->nonce.data()), o->nonce.size());
    if (opened_.contains(tag)) {
      ++stats_.replayed;
      return;
    }
    for (auto& [id, s] : sessions_) {
      if (s->user != o->user || s->where.bytes() != peer) continue;
      end(s, {TransportEnd::Why::peer_closed, "the board opened a new session"}, true);
      break;
    }
    remember(std::move(tag));
    uint32_t id = 0;
    while (id == 0 || sessions_.contains(id)) id = randombytes_random();
    udp::Nonce server_nonce{};
    randombytes_buf(server_nonce.data(), server_nonce.size());

    PeerIdentity identity;
    identity.kind = TransportKind::udp;
    identity.address = from.text();
    identity.account = std::string(o->user);
    auto s = std::make_unique<Session>(loop_, this, std::move(identity),
                                       options_.max_datagram - udp::kDataOverhead);
    s->id = id;
    s->where = from;
    s->key = udp::sessionKey(*key, o->nonce, server_nonce);
    s->client_nonce = o->nonce;
    s->user = std::string(o->user);
    s->accept = udp::makeAccept(*key, o->nonce, id, server_nonce);
    s->last_in = monotonicNs();
    sessions_[id] = s.get();
    ++stats_.sessions;
    sendTo(from, s->accept);
    accepted_(std::move(s));  // may close it at once (too many connections)
  }

  void numbered(std::string_view d, const Peer& from) {
    const auto m = udp::parseNumbered(d);
    if (!m) {
      ++stats_.malformed;
      return;
    }
    const auto it = sessions_.find(m->session);
    if (it == sessions_.end()) {
      ++stats_.unknown_session;
      return;
    }
    Session* s = it->second;
    const udp::Mac64 mac = udp::mac64(s->key, m->signed_part);
    if (!udp::sameMac(mac.data(), m->mac.data(), mac.size())) {
      ++stats_.bad_mac;
      return;
    }
    switch (s->window.take(m->seq, stats_.lost)) {
      case udp::ReplayWindow::Verdict::replayed:
        ++stats_.replayed;
        return;
      case udp::ReplayWindow::Verdict::late:
        ++stats_.reordered;
        break;
      case udp::ReplayWindow::Verdict::fresh:
        break;
    }
    s->last_in = monotonicNs();
    s->where = from;  // the MAC holds: the board's address may have changed (NAT)
    if (m->type == udp::Type::close) {
      end(s, {TransportEnd::Why::peer_closed, "the board closed the session"}, false);
      return;
    }
    if (!udp::wholeFrame(m->frame)) {
      ++stats_.malformed;
      return;
    }
    s->frame(m->frame, stats_);
  }

  // An OPEN that made a session, for as long as its cookie could hold. Only OPENs with a valid
  // cookie and MAC get here (a key holder's); a bounded list all the same.
  void remember(std::string tag) {
    constexpr size_t kMaxOpened = 4096;
    if (opened_.size() >= kMaxOpened) {
      auto oldest =
          std::min_element(opened_.begin(), opened_.end(),
                           [](const auto& a, const auto& b) { return a.second < b.second; });
      opened_.erase(oldest);
    }
    opened_[std::move(tag)] = monotonicNs();
  }

  void sweep() {
    const Nanos now = monotonicNs();
    std::erase_if(opened_,
                  [now](const auto& e) { return now - e.second > 2 * kMinute + kNsPerSec; });
    const Nanos limit = static_cast<Nanos>(options_.session_timeout_ms) * kNsPerMs;
    std::vector<Session*> idle;
    for (auto& [id, s] : sessions_) {
      if (now - s->last_in > limit) idle.push_back(s);
    }
    for (Session* s : idle) {
      ++stats_.timeouts;
      end(s,
          {TransportEnd::Why::error,
           "no datagram for " + std::to_string(options_.session_timeout_ms) + " ms"},
          true);
    }
  }

  // Forgets `s`, telling the board (CLOSE) when `tell`; its transport hears `why` unless empty
  // (it is closing itself).
  void end(Session* s, TransportEnd why, bool tell) noexcept {
    if (sessions_.erase(s->id) == 0) return;
    if (tell)
      sendTo(s->where, udp::makeNumbered(udp::Type::close, s->key, s->id, ++s->seq_out, {}));
    if (!why.message.empty()) s->carrierEnded(std::move(why));
  }

  void sendTo(const Peer& to, const std::string& d) noexcept {
    for (;;) {
      const ssize_t n = ::sendto(fd_, d.data(), d.size(), MSG_DONTWAIT,
                                 reinterpret_cast<const sockaddr*>(&to.addr), to.len);
      if (n < 0 && errno == EINTR) continue;
      if (n < 0) {
        ++stats_.send_failed;  // a full socket buffer: lost, as a datagram on the air is
        return;
      }
      ++stats_.datagrams_out;
      stats_.bytes_out += static_cast<uint64_t>(n);
      return;
    }
  }

  Loop& loop_;
  transport::UdpOptions options_;
  int fd_;
  KeyOf key_of_;
  Accepted accepted_;
  FdWatch watch_;
  Timer sweep_;
  uint16_t port_ = 0;
  udp::Key secret_{};  // the cookies' key, random per start
  std::unordered_map<uint32_t, Session*> sessions_;
  std::map<std::string, Nanos> opened_;  // user | client nonce of the OPENs that made a session
  transport::UdpStats stats_;
};

bool Session::sendFrame(std::string_view frame) {
  port_->sendFrame(*this, frame);
  return true;
}

void Session::leaveCarrier() noexcept {
  port_->leave(this);
}

}  // namespace

Result<std::unique_ptr<UdpPort>> UdpPort::open(Loop& loop, transport::UdpOptions options,
                                               KeyOf key_of, Accepted accepted) {
  if (options.max_datagram < 128 || options.max_datagram > 65507) {
    return makeError(Errc::invalid_argument, "server.udp.max_datagram must be 128 to 65507");
  }
  if (options.session_timeout_ms == 0) {
    return makeError(Errc::invalid_argument, "server.udp.session_timeout_ms must be above 0");
  }
  addrinfo hints{};
  hints.ai_flags = AI_NUMERICHOST | AI_NUMERICSERV | AI_PASSIVE;
  hints.ai_socktype = SOCK_DGRAM;
  addrinfo* res = nullptr;
  const std::string service = std::to_string(options.port);
  if (::getaddrinfo(options.address.c_str(), service.c_str(), &hints, &res) != 0 ||
      res == nullptr) {
    return makeError(Errc::invalid_argument,
                     "server.udp.address \"" + options.address + "\" is not a numeric address");
  }
  const int fd = ::socket(res->ai_family, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (fd < 0 || ::bind(fd, res->ai_addr, res->ai_addrlen) != 0) {
    const int err = errno;
    ::freeaddrinfo(res);
    if (fd >= 0) ::close(fd);
    return makeError(Errc::io_error,
                     "UDP " + options.address + ":" + service + ": " + std::strerror(err));
  }
  ::freeaddrinfo(res);
  auto port =
      std::make_unique<Port>(loop, std::move(options), fd, std::move(key_of), std::move(accepted));
  if (auto r = port->start(); !r) return r.error();
  return std::unique_ptr<UdpPort>(std::move(port));
}

}  // namespace skr::flow
