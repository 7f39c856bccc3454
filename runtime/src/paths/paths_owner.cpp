// SPDX-License-Identifier: Apache-2.0
// Physical mode, the owner's side (see paths.h): the listener, grants, peers, publishing.
#include "paths_impl.h"

#include <skrobot/runtime/flow/address.h>
#include <skrobot/runtime/flow/fd_passing.h>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/stat.h>
#include <sys/un.h>

#include <array>
#include <random>
#include <utility>

namespace skr::flow::phys {

namespace msg = flow::msg;
using namespace paths_io;

// --- the owner's side ---------------------------------------------------------------------------

void Paths::ensureListener() {
  if (listen_fd_ >= 0) return;
  std::random_device rd;
  listen_path_ = "/tmp/skrobot-path-" + std::to_string(::getpid()) + "-" + std::to_string(rd());
  int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  sockaddr_un a{};
  a.sun_family = AF_UNIX;
  std::strncpy(a.sun_path, listen_path_.c_str(), sizeof a.sun_path - 1);
  if (fd < 0 || ::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0 ||
      ::listen(fd, 64) != 0) {
    log::warn(kLogSource, "SAT-PATH",
              "cannot listen at " + listen_path_ + ": " + std::strerror(errno) +
                  "; paths are not offered");
    closeFd(fd);
    listen_path_.clear();
    return;
  }
  auto watch = FdWatch::open(*host_.loop, fd, [this](unsigned) { onAccept(listen_fd_, false); });
  if (!watch) {
    log::warn(kLogSource, "SAT-PATH",
              "cannot listen at " + listen_path_ + ": " + watch.error().message +
                  "; paths are not offered");
    closeFd(fd);
    ::unlink(listen_path_.c_str());
    listen_path_.clear();
    return;
  }
  // Anyone may connect: what lets a connection in is the token the hub gave its subscriber.
  ::chmod(listen_path_.c_str(), 0666);
  listen_fd_ = fd;
  listen_watch_ = std::move(*watch);
  listen_watch_.watch(FdWatch::readable);
}

namespace {

// path_tcp: "<host>:<port>" or "[<IPv6 host>]:<port>", the port written (0: any free one) and
// brackets required (so that the port is not read from the address): host and port, or nullopt.
// (flow::Address reads a hub's address, where the port may be left out and 0 is not one.)
std::optional<std::pair<std::string, uint16_t>> splitHostPort(std::string_view text) {
  std::string_view host, port;
  if (text.starts_with("[")) {
    const auto close = text.find("]:");
    if (close == std::string_view::npos) return std::nullopt;
    host = text.substr(1, close - 1);
    port = text.substr(close + 2);
  } else {
    const auto colon = text.rfind(':');
    if (colon == std::string_view::npos) return std::nullopt;
    host = text.substr(0, colon);
    port = text.substr(colon + 1);
    if (host.find(':') != std::string_view::npos) return std::nullopt;  // IPv6 needs brackets
  }
  if (host.empty() || port.empty() || port.size() > 5 ||
      port.find_first_not_of("0123456789") != std::string_view::npos) {
    return std::nullopt;
  }
  const int n = std::stoi(std::string(port));
  if (n > 65535) return std::nullopt;
  return std::pair{std::string(host), static_cast<uint16_t>(n)};
}

}  // namespace

void Paths::ensureTcpListener() {
  if (tcp_fd_ >= 0 || host_.tcp_listen.empty()) return;
  const std::string& where = host_.tcp_listen;
  const auto split = splitHostPort(where);
  sockaddr_storage a{};
  socklen_t len = 0;
  // Subscribers connect to what we offer: a wildcard address would tell them nothing.
  const auto wildcard = [&] {
    if (a.ss_family == AF_INET) {
      return reinterpret_cast<sockaddr_in*>(&a)->sin_addr.s_addr == htonl(INADDR_ANY);
    }
    return IN6_IS_ADDR_UNSPECIFIED(&reinterpret_cast<sockaddr_in6*>(&a)->sin6_addr);
  };
  if (!split || !numericAddress(split->first, split->second, a, len) || wildcard()) {
    log::warn(kLogSource, "SAT-PATH",
              "path_tcp '" + where +
                  "' is not <address others reach>:<port> (IPv4, or [IPv6]); no direct paths "
                  "over TCP");
    host_.tcp_listen.clear();
    return;
  }
  int fd = ::socket(a.ss_family, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  int one = 1;
  if (fd >= 0) ::setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
  if (fd < 0 || ::bind(fd, reinterpret_cast<sockaddr*>(&a), len) != 0 || ::listen(fd, 64) != 0 ||
      ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len) != 0) {
    log::warn(
        kLogSource, "SAT-PATH",
        "cannot listen at " + where + ": " + std::strerror(errno) + "; no direct paths over TCP");
    closeFd(fd);
    host_.tcp_listen.clear();
    return;
  }
  auto watch = FdWatch::open(*host_.loop, fd, [this](unsigned) { onAccept(tcp_fd_, true); });
  if (!watch) {
    log::warn(
        kLogSource, "SAT-PATH",
        "cannot listen at " + where + ": " + watch.error().message + "; no direct paths over TCP");
    closeFd(fd);
    host_.tcp_listen.clear();
    return;
  }
  const uint16_t port =
      ntohs(a.ss_family == AF_INET ? reinterpret_cast<sockaddr_in*>(&a)->sin_port
                                   : reinterpret_cast<sockaddr_in6*>(&a)->sin6_port);
  tcp_fd_ = fd;
  tcp_endpoint_ =
      flow::Address{.kind = flow::Address::Kind::tcp, .host = split->first, .port = port}
          .toString();
  tcp_watch_ = std::move(*watch);
  tcp_watch_.watch(FdWatch::readable);
  log::info(kLogSource, "SAT-PATH", "direct paths over TCP at " + tcp_endpoint_);
}

void Paths::serve(uint16_t chan_id, const std::string& name, uint8_t kinds,
                  const shm::RingGeometry& ring) {
  kinds &= msg::kPhysDirect | msg::kPhysShm;
  if (kinds == 0) return;
  ensureListener();
  if (listen_fd_ < 0) return;
  auto s = std::make_unique<Served>();
  s->chan_id = chan_id;
  s->name = name;
  // A channel created again (a reconnection) keeps its ring, and its readers come back to it.
  if (auto idle = idle_rings_.find(name); idle != idle_rings_.end()) {
    s->ring = std::move(idle->second);
    idle_rings_.erase(idle);
  }
  if ((kinds & msg::kPhysShm) != 0 && !s->ring) {
    auto r = flow::shm::RingWriter::create("skrobot:" + name, ring);
    if (r) {
      s->ring = std::move(*r);
    } else {
      log::warn(kLogSource, "SAT-PATH",
                name + ": no shared memory (" + r.error().message + "); direct only");
      kinds &= ~msg::kPhysShm;
    }
  }
  s->paths = kinds;
  served_[chan_id] = std::move(s);
  if (kinds == 0) return;
  std::string endpoint = "unix:" + listen_path_;
  // Other machines: direct paths over TCP as well, to a hub that takes two endpoints (1.8).
  if ((kinds & msg::kPhysDirect) != 0 && host_.hub_minor() >= 8) {
    ensureTcpListener();
    if (!tcp_endpoint_.empty()) endpoint += " " + tcp_endpoint_;
  }
  host_.offer(msg::PhysOffer{host_.next_tag(), chan_id, kinds, endpoint});
}

bool Paths::hasRing(uint16_t chan_id) const {
  auto s = served_.find(chan_id);
  return s != served_.end() && s->second->ring.has_value();
}

void Paths::unserve(uint16_t chan_id) {
  auto s = served_.find(chan_id);
  if (s == served_.end()) return;
  std::erase_if(grants_, [&](const auto& g) { return g.second.chan_id == chan_id; });
  std::vector<int> gone;
  for (auto& [fd, p] : peers_) {
    if (p->chan_id == chan_id) gone.push_back(fd);
  }
  for (int fd : gone) closePeer(fd, "the channel was removed");
  if (s->second->ring) idle_rings_.emplace(s->second->name, std::move(*s->second->ring));
  served_.erase(s);
}

void Paths::onGrant(const msg::EvPhysGrant& m) {
  if (served_.count(m.chan_id) == 0) return;
  grants_[m.token] = Grant{m.chan_id, m.subscriber, m.path, monotonicNs() + kGrantLifetimeNs};
  // The hub tells both ends at once: the subscriber's HELLO may have come first.
  for (auto& [fd, peer] : peers_) {
    if (peer->pending_token != m.token) continue;
    const std::string hello = std::exchange(peer->pending_hello, {});
    peer->pending_token.clear();
    welcome(*peer, hello);  // may close the peer: stop iterating
    return;
  }
}

void Paths::onRevoke(const msg::EvPhysRevoke& m) {
  std::erase_if(grants_, [&](const auto& g) {
    return g.second.chan_id == m.chan_id && g.second.subscriber == m.subscriber;
  });
  std::vector<int> gone;
  for (auto& [fd, p] : peers_) {
    if (p->chan_id == m.chan_id && p->subscriber == m.subscriber) gone.push_back(fd);
  }
  for (int fd : gone) closePeer(fd, "revoked by the hub");
}

void Paths::onRelay(const msg::EvPhysRelay& m) {
  if (auto s = served_.find(m.chan_id); s != served_.end()) {
    s->second->relay_needed = m.needed != 0;
    return;
  }
  if (auto p = paths_.find(m.chan_id); p != paths_.end() && m.needed == 0) {
    onMarker(*p->second, std::nullopt);
  }
}

void Paths::onSwitch(const msg::EvPhysSwitch& m) {
  auto s = served_.find(m.chan_id);
  if (s == served_.end()) return;
  for (auto& [fd, p] : peers_) {
    if (p->chan_id != m.chan_id || p->subscriber != m.subscriber || p->path == 0) continue;
    // The numbering of that subscriber's path: the ring's, or the direct frames'.
    const Served& sv = *s->second;
    const uint64_t seq = p->path == msg::kPhysShm && sv.ring ? sv.ring->published() : sv.seq;
    host_.switched(msg::PhysSwitched{m.chan_id, m.subscriber, m.switch_id, seq});
    return;
  }
  // No such peer (it left since): its subscriber falls back, and the hub drops the switch.
}

void Paths::onResume(const msg::EvPhysResume& m) {
  auto s = served_.find(m.chan_id);
  if (s == served_.end()) return;  // gone with its channel: the hub relays without us
  Served& sv = *s->second;
  uint64_t replayed = 0;
  for (const auto& [seq, payload] : sv.kept) {
    if (seq <= m.after) continue;
    host_.replay(msg::PhysReplay{m.chan_id, m.subscriber, m.resume_id, 0, 0, msg::Rest{payload}});
    ++replayed;
  }
  const uint64_t lost = sv.seq > m.after ? sv.seq - m.after - replayed : 0;
  host_.replay(msg::PhysReplay{m.chan_id, m.subscriber, m.resume_id, 1, lost, msg::Rest{}});
  sv.relay_needed = true;  // the subscriber is relayed from here on
  if (lost != 0) {
    log::warn(kLogSource, "SAT-PATH-LOST",
              sv.name + ": " + std::to_string(lost) + " messages for flow " +
                  std::to_string(m.subscriber) + " were no longer kept when its path broke");
  }
}

void Paths::onAccept(int listen_fd, bool tcp) {
  for (;;) {
    int fd = ::accept4(listen_fd, nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC);
    if (fd < 0) return;
    if (tcp) {
      int one = 1;
      ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    }
    auto p = std::make_unique<Peer>();
    p->owner = this;
    p->fd = fd;
    p->tcp = tcp;
    // Room for a large frame in the kernel (capped at net.core.wmem_max x 2): fewer trips
    // through the loop per frame than the default 208 KB.
    const int sndbuf = 8 << 20;
    ::setsockopt(fd, SOL_SOCKET, SO_SNDBUF, &sndbuf, sizeof sndbuf);
    p->opened = monotonicNs();
    auto watch = FdWatch::open(*host_.loop, fd, [peer = p.get()](unsigned events) {
      peer->owner->onPeer(*peer, pathEvents(events));
    });
    if (!watch) {
      log::warn(kLogSource, "SAT-PATH-REFUSED", "a path connection: " + watch.error().message);
      ::close(fd);
      continue;
    }
    p->watch = std::move(*watch);
    p->watch.watch(FdWatch::readable | FdWatch::hangup);
    peers_[fd] = std::move(p);
  }
}

void Paths::onPeer(Peer& p, unsigned events) {
  const int fd = p.fd;
  if ((events & FdWatch::writable) != 0 && !p.out.empty()) {
    const std::string_view rest = writeSome(fd, p.out);
    p.out.erase(0, p.out.size() - rest.size());
    if (p.out.empty()) p.watch.watch(FdWatch::readable | FdWatch::hangup);
  }
  if ((events & (FdWatch::readable | FdWatch::hangup)) == 0) return;
  char buf[4096];
  const ssize_t n = ::recv(fd, buf, sizeof buf, 0);
  if (n == 0 || (n < 0 && errno != EAGAIN && errno != EINTR)) {
    closePeer(fd, n == 0 ? "the subscriber left" : std::strerror(errno));
    return;
  }
  if (n < 0) return;
  // Nothing is expected after HELLO but BYE or the close.
  if (p.path != 0 || !p.pending_hello.empty()) return;
  p.in.append(buf, static_cast<size_t>(n));
  const auto f = flow::path::next(p.in, flow::path::kMaxControlBytes);
  if (f.status == flow::path::Next::Status::too_large ||
      (f.status == flow::path::Next::Status::frame && f.type != uint8_t(flow::path::Type::hello))) {
    closePeer(fd, "not a path HELLO");
    return;
  }
  if (f.status == flow::path::Next::Status::frame) welcome(p, f.body);
}

void Paths::refusePeer(Peer& p, const std::string& why) {
  (void)writeSome(p.fd, flow::path::encode(flow::path::Welcome{
                            uint16_t(flow::ErrorCode::permission_denied), why}));
  log::warn(kLogSource, "SAT-PATH-REFUSED", "a path connection: " + why);
  closePeer(p.fd, why);
}

void Paths::welcome(Peer& p, std::string_view body) {
  const auto refuse = [&](const std::string& why) { refusePeer(p, why); };
  const auto hello = flow::path::decodeHello(body);
  if (!hello) return refuse("a malformed HELLO");
  const uint8_t path = hello->path;
  const std::string& channel = hello->channel;
  auto g = grants_.find(hello->token);
  if (g == grants_.end() && p.pending_until == 0) {
    // Its grant may still be on its way to us (the hub sends both at once): wait for it a while.
    p.pending_hello = std::string(body);
    p.pending_token = hello->token;
    p.pending_until = monotonicNs() + kHelloWaitNs;
    return;
  }
  if (g == grants_.end() || g->second.expires < monotonicNs() || g->second.path != path) {
    return refuse("no such grant (a token is good once, for 10 s)");
  }
  const Grant grant = g->second;
  grants_.erase(g);  // once
  auto s = served_.find(grant.chan_id);
  if (s == served_.end() || s->second->name != channel) return refuse("not the granted channel");
  p.chan_id = grant.chan_id;
  p.subscriber = grant.subscriber;
  const std::string ok = flow::path::encode(flow::path::Welcome{});
  if (path == msg::kPhysShm) {
    if (p.tcp) return refuse("shared memory is not served over TCP");
    if (!s->second->ring) return refuse("no shared memory here");
    auto fds = s->second->ring->addReader();
    if (!fds) return refuse(fds.error().message);
    const std::array<int, 3> pass{fds->ring, fds->lease_page, fds->event};
    auto sent = flow::sendWithFds(p.fd, ok, pass);
    for (int fd : pass) ::close(fd);
    if (!sent) {
      s->second->ring->removeReader(fds->lease);
      closePeer(p.fd, sent.error().message);
      return;
    }
    p.lease = fds->lease;
    ++stats_.served_shm;
  } else {
    if (!writeSome(p.fd, ok).empty()) return closePeer(p.fd, "cannot write WELCOME");
    ++stats_.served_direct;
  }
  p.path = path;
  p.in.clear();
  log::info(kLogSource, "SAT-PATH-OPEN",
            s->second->name + " to flow " + std::to_string(p.subscriber) + " by " +
                (path == msg::kPhysShm ? "shared memory" : "a direct socket"));
}

void Paths::closePeer(int fd, const std::string& why) {
  auto it = peers_.find(fd);
  if (it == peers_.end()) return;
  Peer& p = *it->second;
  if (p.path == msg::kPhysShm) {
    if (auto s = served_.find(p.chan_id); s != served_.end() && s->second->ring) {
      s->second->ring->removeReader(p.lease);
    }
    --stats_.served_shm;
  } else if (p.path == msg::kPhysDirect) {
    --stats_.served_direct;
    // Its subscriber may fall back and ask for what it missed: keep on keeping a while.
    if (auto s = served_.find(p.chan_id); s != served_.end()) {
      s->second->keep_until = monotonicNs() + kGrantLifetimeNs;
    }
  }
  if (p.path != 0) {
    (void)writeSome(fd, flow::path::encodeBye(why));
    log::info(kLogSource, "SAT-PATH-CLOSED", "flow " + std::to_string(p.subscriber) + ": " + why);
  }
  p.watch = FdWatch();
  ::close(fd);
  peers_.erase(it);
}

bool Paths::publish(uint16_t chan_id, std::string_view payload, int64_t capture_ns) {
  auto s = served_.find(chan_id);
  if (s == served_.end()) return true;
  Served& sv = *s->second;
  if (sv.ring && sv.ring->readers() > 0) {
    (void)sv.ring->publish(std::as_bytes(std::span(payload.data(), payload.size())), capture_ns);
  }
  return sendDirect(sv, payload, capture_ns);
}

bool Paths::sendDirect(Served& sv, std::string_view payload, int64_t capture_ns) {
  ++sv.seq;
  std::string head;
  bool direct = false;
  for (auto& [fd, p] : peers_) {
    if (p->chan_id != sv.chan_id || p->path != msg::kPhysDirect) continue;
    direct = true;
    if (head.empty()) head = flow::path::dataHead(sv.seq, capture_ns, payload.size());
    if (p->out.size() + head.size() + payload.size() > kMaxPeerQueue) {
      ++p->dropped;  // a slow direct subscriber: what waits goes first, this one is dropped
      continue;
    }
    if (p->out.empty()) {
      // Straight to the socket when nothing waits.
      const size_t done = writeSome(fd, head, payload);
      if (done < head.size()) {
        p->out.append(std::string_view(head).substr(done)).append(payload);
      } else {
        p->out.append(payload.substr(done - head.size()));
      }
    } else {
      p->out.append(head).append(payload);
    }
    if (!p->out.empty()) p->watch.watch(FdWatch::readable | FdWatch::writable | FdWatch::hangup);
  }
  // Only a hub of 1.11 ever asks for them back (EV_PHYS_RESUME).
  if ((direct || (sv.keep_until != 0 && monotonicNs() < sv.keep_until)) &&
      host_.hub_minor() >= 11) {
    keep(sv, payload);
  }
  if (!sv.relay_needed) {
    ++sv.unrelayed_messages;
    sv.unrelayed_bytes += payload.size();
  }
  return sv.relay_needed;
}

void Paths::keep(Served& sv, std::string_view payload) {
  if (payload.size() <= kKeptMessageBytes) {
    // Into a buffer let go before when there is one: no allocation, no fresh pages to fault in.
    std::string copy;
    if (!sv.spare.empty()) {
      copy = std::move(sv.spare.back());
      sv.spare.pop_back();
    }
    copy.assign(payload);
    sv.kept.emplace_back(sv.seq, std::move(copy));
    sv.kept_bytes += payload.size();
  }
  while (!sv.kept.empty() && sv.kept_bytes > kKeptBytes) {
    sv.kept_bytes -= sv.kept.front().second.size();
    if (sv.spare.size() < kSpareBuffers) sv.spare.push_back(std::move(sv.kept.front().second));
    sv.kept.pop_front();
  }
}

std::span<std::byte> Paths::beginPublish(uint16_t chan_id) {
  auto s = served_.find(chan_id);
  if (s == served_.end() || !s->second->ring) return {};
  return s->second->ring->beginWrite();
}

std::optional<std::string_view> Paths::commitPublish(uint16_t chan_id, size_t size,
                                                     int64_t capture_ns, bool& relay) {
  auto s = served_.find(chan_id);
  if (s == served_.end() || !s->second->ring) return std::nullopt;
  auto slot = s->second->ring->beginWrite();  // the same slot, still marked
  if (slot.empty() || size > slot.size() || !s->second->ring->commit(size, capture_ns)) {
    return std::nullopt;
  }
  // The other paths and the hub get the bytes from the slot, which stays as it is until the next
  // beginWrite.
  const std::string_view bytes(reinterpret_cast<const char*>(slot.data()), size);
  relay = sendDirect(*s->second, bytes, capture_ns);
  return bytes;
}

}  // namespace skr::flow::phys
