// Physical mode in a satellite (see paths.h).
#include "paths.h"

#include <skrobot/core/log.h>
#include <skrobot/flow/bytes.h>
#include <skrobot/flow/fd_passing.h>
#include <skrobot/flow/path_framing.h>
#include <skrobot/satellite/satellite.h>

#include <arpa/inet.h>
#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstring>
#include <random>

namespace skr::sat::detail {
namespace {

namespace msg = flow::msg;
constexpr const char* kLogSource = "satellite";
constexpr uint32_t kMaxDataFrame = flow::path::kMaxDataBytes + 32;
constexpr size_t kMaxPeerQueue = 16u << 20;  // a direct subscriber's backlog; beyond: drops
constexpr Nanos kRetryMinNs = kNsPerSec, kRetryMaxNs = 30 * kNsPerSec;

uv_poll_t* newPoll(uv_loop_t* loop, int fd, void* data) {
  auto* p = new uv_poll_t{};
  uv_poll_init(loop, p, fd);
  p->data = data;
  return p;
}
void closePoll(uv_poll_t*& p) {
  if (p == nullptr) return;
  uv_poll_stop(p);
  uv_close(reinterpret_cast<uv_handle_t*>(p),
           [](uv_handle_t* h) { delete reinterpret_cast<uv_poll_t*>(h); });
  p = nullptr;
}
void closeFd(int& fd) {
  if (fd >= 0) ::close(fd);
  fd = -1;
}

// Writes all of `bytes` on a non-blocking socket, or what fits; the rest is returned.
std::string_view writeSome(int fd, std::string_view bytes) {
  while (!bytes.empty()) {
    const ssize_t n = ::send(fd, bytes.data(), bytes.size(), MSG_NOSIGNAL);
    if (n < 0) {
      if (errno == EINTR) continue;
      return bytes;  // EAGAIN, or an error the read side will see
    }
    bytes.remove_prefix(static_cast<size_t>(n));
  }
  return bytes;
}

// Bytes read from a path socket, received straight into place (no zero-filling, no copy from a
// bounce buffer): a large frame is read into memory that already has its size.
class InBuffer {
 public:
  [[nodiscard]] std::string_view view() const { return {data_.get() + head_, len_}; }
  [[nodiscard]] bool empty() const { return len_ == 0; }
  void append(std::string_view b) {
    std::memcpy(tail(b.size()), b.data(), b.size()), len_ += b.size();
  }
  // Room for `n` more bytes at the end; commit(k) keeps the k read there.
  char* tail(size_t n) {
    if (head_ + len_ + n > cap_) {
      const size_t cap = std::max(cap_ * 2, len_ + n);
      if (len_ + n <= cap_ && head_ > 0) {
        std::memmove(data_.get(), data_.get() + head_, len_);
      } else {
        std::unique_ptr<char[]> d(new char[cap]);
        if (len_ > 0) std::memcpy(d.get(), data_.get() + head_, len_);
        data_ = std::move(d);
        cap_ = cap;
      }
      head_ = 0;
    }
    return data_.get() + head_ + len_;
  }
  void commit(size_t n) { len_ += n; }
  void consume(size_t n) {
    head_ += n;
    len_ -= n;
    if (len_ == 0) head_ = 0;
  }
  void clear() { head_ = len_ = 0; }

 private:
  std::unique_ptr<char[]> data_;
  size_t cap_ = 0, head_ = 0, len_ = 0;
};

}  // namespace

struct Paths::Served {
  uint16_t chan_id = 0;
  std::string name;
  uint8_t paths = 0;
  std::optional<flow::shm::RingWriter> ring;
  bool relay_needed = true;
  uint64_t seq = 0;
  uint64_t unrelayed_messages = 0, unrelayed_bytes = 0;  // for PHYS_COUNT
};

struct Paths::Peer {
  Paths* owner = nullptr;
  int fd = -1;
  uv_poll_t* poll = nullptr;
  std::string in, out;
  uint8_t path = 0;  // 0 until WELCOME
  uint16_t chan_id = 0;
  uint32_t subscriber = 0;
  uint32_t lease = 0;
  Nanos opened = 0;
  uint64_t dropped = 0;
};

struct Paths::Path {
  Paths* owner = nullptr;
  std::string name;
  uint16_t chan_id = 0;
  uint32_t tag = 0;  // PHYS_REQUEST in flight
  uint8_t path = 0;
  int fd = -1;
  uv_poll_t* poll = nullptr;
  uv_poll_t* event_poll = nullptr;
  std::optional<flow::shm::RingReader> reader;
  InBuffer in;
  bool open = false;    // WELCOME came
  bool marker = false;  // the hub relays no more: what comes on the path is ours
  Nanos retry_at = 0;   // 0: not waiting to ask again
  int failures = 0;
};

Paths::Paths(Host host) : host_(std::move(host)) {}

Paths::~Paths() {
  reset();
  for (auto& [id, p] : paths_) closePoll(p->poll);
  closePoll(listen_poll_);
  closeFd(listen_fd_);
  if (!listen_path_.empty()) ::unlink(listen_path_.c_str());
}

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
  // Anyone may connect: what lets a connection in is the token the hub gave its subscriber.
  ::chmod(listen_path_.c_str(), 0666);
  listen_fd_ = fd;
  listen_poll_ = newPoll(host_.loop, fd, this);
  uv_poll_start(listen_poll_, UV_READABLE,
                [](uv_poll_t* h, int, int) { static_cast<Paths*>(h->data)->onAccept(); });
}

void Paths::serve(uint16_t chan_id, const std::string& name, const PhysicalOptions& o) {
  uint8_t kinds = (o.direct ? msg::kPhysDirect : 0) | (o.shm ? msg::kPhysShm : 0);
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
  if (o.shm && !s->ring) {
    auto r = flow::shm::RingWriter::create("skrobot:" + name, o.ring);
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
  if (kinds != 0)
    host_.offer(msg::PhysOffer{host_.next_tag(), chan_id, kinds, "unix:" + listen_path_});
}

void Paths::onGrant(const msg::EvPhysGrant& m) {
  if (served_.count(m.chan_id) == 0) return;
  grants_[m.token] = Grant{m.chan_id, m.subscriber, m.path, monotonicNs() + kGrantLifetimeNs};
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
  if (auto p = paths_.find(m.chan_id); p != paths_.end() && m.needed == 0) p->second->marker = true;
}

void Paths::onAccept() {
  for (;;) {
    int fd = ::accept4(listen_fd_, nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC);
    if (fd < 0) return;
    auto p = std::make_unique<Peer>();
    p->owner = this;
    p->fd = fd;
    p->opened = monotonicNs();
    p->poll = newPoll(host_.loop, fd, p.get());
    uv_poll_start(p->poll, UV_READABLE | UV_DISCONNECT, [](uv_poll_t* h, int status, int events) {
      auto* peer = static_cast<Peer*>(h->data);
      peer->owner->onPeer(*peer, status < 0 ? UV_DISCONNECT : events);
    });
    peers_[fd] = std::move(p);
  }
}

void Paths::onPeer(Peer& p, int events) {
  const int fd = p.fd;
  if ((events & UV_WRITABLE) != 0 && !p.out.empty()) {
    const std::string_view rest = writeSome(fd, p.out);
    p.out.erase(0, p.out.size() - rest.size());
    if (p.out.empty()) uv_poll_start(p.poll, UV_READABLE | UV_DISCONNECT, p.poll->poll_cb);
  }
  if ((events & (UV_READABLE | UV_DISCONNECT)) == 0) return;
  char buf[4096];
  const ssize_t n = ::recv(fd, buf, sizeof buf, 0);
  if (n == 0 || (n < 0 && errno != EAGAIN && errno != EINTR)) {
    closePeer(fd, n == 0 ? "the subscriber left" : std::strerror(errno));
    return;
  }
  if (n < 0) return;
  if (p.path != 0) return;  // nothing is expected after HELLO but BYE or the close
  p.in.append(buf, static_cast<size_t>(n));
  const auto f = flow::path::next(p.in, flow::path::kMaxControlBytes);
  if (f.status == flow::path::Next::Status::too_large ||
      (f.status == flow::path::Next::Status::frame && f.type != uint8_t(flow::path::Type::hello))) {
    closePeer(fd, "not a path HELLO");
    return;
  }
  if (f.status == flow::path::Next::Status::frame) welcome(p, f.body);
}

void Paths::welcome(Peer& p, std::string_view body) {
  auto refuse = [&](const std::string& why) {
    (void)writeSome(p.fd, flow::path::encode(flow::path::Welcome{
                              uint16_t(flow::ErrorCode::permission_denied), why}));
    log::warn(kLogSource, "SAT-PATH-REFUSED", "a path connection: " + why);
    closePeer(p.fd, why);
  };
  const auto hello = flow::path::decodeHello(body);
  if (!hello) return refuse("a malformed HELLO");
  const uint8_t path = hello->path;
  const std::string& channel = hello->channel;
  auto g = grants_.find(hello->token);
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
  }
  if (p.path != 0) {
    (void)writeSome(fd, flow::path::encodeBye(why));
    log::info(kLogSource, "SAT-PATH-CLOSED", "flow " + std::to_string(p.subscriber) + ": " + why);
  }
  closePoll(p.poll);
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
  for (auto& [fd, p] : peers_) {
    if (p->chan_id != sv.chan_id || p->path != msg::kPhysDirect) continue;
    if (head.empty()) head = flow::path::dataHead(sv.seq, capture_ns, payload.size());
    if (p->out.size() + head.size() + payload.size() > kMaxPeerQueue) {
      ++p->dropped;  // a slow direct subscriber: what waits goes first, this one is dropped
      continue;
    }
    if (p->out.empty()) {
      // Straight to the socket when nothing waits.
      const std::string_view head_left = writeSome(fd, head);
      if (head_left.empty()) {
        p->out.append(writeSome(fd, payload));
      } else {
        p->out.append(head_left).append(payload);
      }
    } else {
      p->out.append(head).append(payload);
    }
    if (!p->out.empty()) {
      uv_poll_start(p->poll, UV_READABLE | UV_WRITABLE | UV_DISCONNECT, p->poll->poll_cb);
    }
  }
  if (!sv.relay_needed) {
    ++sv.unrelayed_messages;
    sv.unrelayed_bytes += payload.size();
  }
  return sv.relay_needed;
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

// --- the subscriber's side
// ------------------------------------------------------------------------

void Paths::want(const std::string& name, uint8_t paths) {
  if (paths == 0) {
    wanted_.erase(name);
  } else {
    wanted_[name] = paths;
  }
}

void Paths::onSubscribed(const std::string& name, uint16_t chan_id) {
  auto w = wanted_.find(name);
  if (w == wanted_.end()) return;
  auto p = std::make_unique<Path>();
  p->owner = this;
  p->name = name;
  p->chan_id = chan_id;
  request(*p);
  paths_[chan_id] = std::move(p);
}

void Paths::request(Path& p) {
  auto w = wanted_.find(p.name);
  if (w == wanted_.end()) return;
  p.tag = host_.next_tag();
  p.retry_at = 0;
  host_.request(msg::PhysRequest{p.tag, p.chan_id, w->second});
}

void Paths::onRefused(uint32_t tag) {
  for (auto& [id, p] : paths_) {
    if (p->tag != tag) continue;
    p->tag = 0;
    ++p->failures;
    p->retry_at = monotonicNs() + std::min(kRetryMaxNs, kRetryMinNs << std::min(p->failures, 5));
    return;
  }
}

void Paths::onUnsubscribed(uint16_t chan_id) {
  auto it = paths_.find(chan_id);
  if (it == paths_.end()) return;
  Path& p = *it->second;
  closePoll(p.poll);
  closePoll(p.event_poll);
  p.reader.reset();
  closeFd(p.fd);
  paths_.erase(it);
}

void Paths::onPath(const msg::EvPhysPath& m) {
  auto it = paths_.find(m.chan_id);
  if (it == paths_.end() || it->second->tag != m.tag) return;
  Path& p = *it->second;
  p.tag = 0;
  p.path = m.path;
  connectPath(p, m.endpoint);
  if (p.fd < 0) return failPath(m.chan_id, "cannot connect to " + m.endpoint);
  const std::string hello = flow::path::encode(flow::path::Hello{1, m.path, p.name, m.token});
  if (!writeSome(p.fd, hello).empty()) return failPath(m.chan_id, "cannot send HELLO");
  p.poll = newPoll(host_.loop, p.fd, &p);
  uv_poll_start(p.poll, UV_READABLE | UV_DISCONNECT, [](uv_poll_t* h, int status, int events) {
    auto* path = static_cast<Path*>(h->data);
    path->owner->onPathSocket(*path, status < 0 ? UV_DISCONNECT : events);
  });
}

void Paths::connectPath(Path& p, const std::string& endpoint) {
  if (endpoint.rfind("unix:", 0) == 0) {
    const std::string where = endpoint.substr(5);
    int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_un a{};
    a.sun_family = AF_UNIX;
    if (fd < 0 || where.size() >= sizeof a.sun_path) return closeFd(fd);
    std::memcpy(a.sun_path, where.data(), where.size());
    // A local connect does not wait on the network: done blocking, then made non-blocking.
    if (::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) return closeFd(fd);
    ::fcntl(fd, F_SETFL, ::fcntl(fd, F_GETFL) | O_NONBLOCK);
    p.fd = fd;
    return;
  }
  if (endpoint.rfind("tcp:", 0) == 0) {
    const std::string rest = endpoint.substr(4);
    const auto colon = rest.rfind(':');
    if (colon == std::string::npos) return;
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(static_cast<uint16_t>(std::atoi(rest.c_str() + colon + 1)));
    // A numeric address only: no name lookup on the loop thread.
    if (::inet_pton(AF_INET, rest.substr(0, colon).c_str(), &a.sin_addr) != 1) return;
    int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    if (fd < 0) return;
    if (::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) return closeFd(fd);
    int one = 1;
    ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    ::fcntl(fd, F_SETFL, ::fcntl(fd, F_GETFL) | O_NONBLOCK);
    p.fd = fd;
  }
}

void Paths::onPathSocket(Path& p, int events) {
  if ((events & (UV_READABLE | UV_DISCONNECT)) == 0) return;
  const uint16_t chan = p.chan_id;
  if (!p.open) {
    auto got = flow::receiveWithFds(p.fd, 64 * 1024);
    if (!got || got->bytes.empty()) {
      for (int fd : got ? got->fds : std::vector<int>{}) ::close(fd);
      return failPath(chan, got ? "the owner closed the path" : got.error().message);
    }
    p.in.append(got->bytes);
    const auto f = flow::path::next(p.in.view(), flow::path::kMaxControlBytes);
    const auto welcome =
        f.status == flow::path::Next::Status::frame && f.type == uint8_t(flow::path::Type::welcome)
            ? flow::path::decodeWelcome(f.body)
            : std::nullopt;
    if (!welcome || welcome->error != 0) {
      for (int fd : got->fds) ::close(fd);
      if (f.status == flow::path::Next::Status::need_more) {
        return failPath(chan, "a WELCOME in pieces");
      }
      return failPath(
          chan, welcome ? "refused: " + welcome->message : "the owner did not answer with WELCOME");
    }
    p.in.consume(f.size);
    if (p.path == msg::kPhysShm) {
      if (got->fds.size() != 3) {
        for (int fd : got->fds) ::close(fd);
        return failPath(chan, "a shared-memory WELCOME without its three descriptors");
      }
      auto reader = flow::shm::RingReader::open(got->fds[0], got->fds[1], got->fds[2]);
      if (!reader) return failPath(chan, reader.error().message);
      p.reader = std::move(*reader);
      p.event_poll = newPoll(host_.loop, p.reader->eventFd(), &p);
      uv_poll_start(p.event_poll, UV_READABLE, [](uv_poll_t* h, int, int) {
        auto* path = static_cast<Path*>(h->data);
        path->owner->onPathEvent(*path);
      });
    } else {
      for (int fd : got->fds) ::close(fd);
    }
    p.open = true;
    p.failures = 0;
    host_.state(msg::PhysState{chan, 1});
    log::info(kLogSource, "SAT-PATH-OPEN",
              p.name + " by " + (p.path == msg::kPhysShm ? "shared memory" : "a direct socket"));
    if (!p.in.empty()) pathFrames(p);
    return;
  }
  for (;;) {
    // As much as the frame being read still needs (at least 64 KB), straight into place.
    size_t want = 64 * 1024;
    const std::string_view have = p.in.view();
    if (have.size() >= 4) {
      uint32_t n = 0;
      std::memcpy(&n, have.data(), 4);
      if (n <= kMaxDataFrame && 4 + size_t(n) > have.size()) {
        want = std::max(want, 4 + size_t(n) - have.size());
      }
    }
    const ssize_t n = ::recv(p.fd, p.in.tail(want), want, 0);
    if (n == 0) return failPath(chan, "the owner closed the path");
    if (n < 0) {
      if (errno == EAGAIN || errno == EINTR) break;
      return failPath(chan, std::strerror(errno));
    }
    p.in.commit(static_cast<size_t>(n));
    if (static_cast<size_t>(n) < want) break;
  }
  pathFrames(p);
}

void Paths::pathFrames(Path& p) {
  const uint16_t chan = p.chan_id;
  size_t used = 0;
  for (;;) {
    const auto f = flow::path::next(p.in.view().substr(used), flow::path::kMaxDataBytes + 32);
    if (f.status == flow::path::Next::Status::too_large) {
      return failPath(chan, "a path frame of " + std::to_string(f.announced) + " bytes");
    }
    if (f.status == flow::path::Next::Status::need_more) break;
    used += f.size;
    if (f.type == uint8_t(flow::path::Type::bye)) return failPath(chan, "the owner said goodbye");
    const auto data =
        f.type == uint8_t(flow::path::Type::data) ? flow::path::decodeData(f.body) : std::nullopt;
    if (!data) return failPath(chan, "an unexpected path frame");
    if (!p.marker) {
      ++stats_.dropped_before_marker;
      continue;
    }
    ++stats_.path_messages;
    host_.deliver(chan, data->payload);
    if (paths_.count(chan) == 0) return;  // a slot unsubscribed
  }
  p.in.consume(used);
}

void Paths::onPathEvent(Path& p) {
  if (!p.reader) return;
  p.reader->drain();
  const uint16_t chan = p.chan_id;
  const auto status = p.reader->readLatest([&](std::span<const std::byte> bytes, const auto&) {
    if (!p.marker) {
      ++stats_.dropped_before_marker;
      return;
    }
    ++stats_.path_messages;
    host_.deliver(chan,
                  std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()));
  });
  if (status == flow::shm::ReadStatus::torn) ++stats_.torn;
}

void Paths::failPath(uint16_t chan_id, const std::string& why) {
  auto it = paths_.find(chan_id);
  if (it == paths_.end()) return;
  Path& p = *it->second;
  const bool was_open = p.open;
  closePoll(p.poll);
  closePoll(p.event_poll);
  p.reader.reset();
  closeFd(p.fd);
  p.in.clear();
  p.open = false;
  p.marker = false;
  p.tag = 0;
  ++p.failures;
  ++stats_.fallbacks;
  p.retry_at = monotonicNs() + std::min(kRetryMaxNs, kRetryMinNs << std::min(p.failures, 5));
  if (was_open) host_.state(msg::PhysState{chan_id, 0});  // relayed again
  log::warn(kLogSource, "SAT-PATH-FALLBACK",
            p.name + ": " + why + "; relayed by the hub meanwhile");
}

// --- both ---------------------------------------------------------------------------------------

void Paths::closeAll(const std::string& why) {
  std::vector<int> fds;
  for (auto& [fd, p] : peers_) fds.push_back(fd);
  for (int fd : fds) closePeer(fd, why);
  std::vector<uint16_t> chans;
  for (auto& [id, p] : paths_) {
    if (p->fd >= 0) chans.push_back(id);
  }
  for (uint16_t id : chans) failPath(id, why);
}

void Paths::tick() {
  const Nanos now = monotonicNs();
  for (auto& [id, s] : served_) {
    if (s->unrelayed_messages == 0) continue;
    host_.count(msg::PhysCount{id, s->unrelayed_messages, s->unrelayed_bytes});
    s->unrelayed_messages = s->unrelayed_bytes = 0;
  }
  std::erase_if(grants_, [&](const auto& g) { return g.second.expires < now; });
  for (auto& [id, p] : paths_) {
    if (p->reader) p->reader->heartbeat();
    if (!p->open && p->tag == 0 && p->retry_at != 0 && p->retry_at <= now) request(*p);
  }
}

void Paths::reset() {
  std::vector<int> fds;
  for (auto& [fd, p] : peers_) fds.push_back(fd);
  for (int fd : fds) closePeer(fd, "the owner lost the hub");
  grants_.clear();
  for (auto& [id, p] : paths_) {
    closePoll(p->poll);
    closePoll(p->event_poll);
    p->reader.reset();
    closeFd(p->fd);
  }
  paths_.clear();
  // Ids change with the next flow: our channels are offered again when created; rings wait.
  for (auto& [id, sv] : served_) {
    if (sv->ring) idle_rings_.emplace(sv->name, std::move(*sv->ring));
  }
  served_.clear();
}

Paths::Stats Paths::stats() const {
  return stats_;
}

}  // namespace skr::sat::detail
