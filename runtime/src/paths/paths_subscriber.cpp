// SPDX-License-Identifier: Apache-2.0
// Physical mode, the subscriber's side (see paths.h): paths asked for, connected, read, and their
// fallback.
#include "paths_impl.h"

#include <skrobot/runtime/flow/address.h>
#include <skrobot/runtime/flow/fd_passing.h>

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sched.h>
#include <sys/un.h>

namespace skr::flow::phys {

namespace msg = flow::msg;
using namespace paths_io;

// --- the subscriber's side
// ------------------------------------------------------------------------

void Paths::want(const std::string& name, uint8_t paths, bool spin) {
  if (paths == 0) {
    wanted_.erase(name);
  } else {
    wanted_[name] = Wanted{paths, spin};
  }
}

void Paths::onSubscribed(const std::string& name, uint16_t chan_id) {
  auto w = wanted_.find(name);
  if (w == wanted_.end()) return;
  onUnsubscribed(chan_id);  // asked again (usePaths on a followed channel): a new path
  auto p = std::make_unique<Path>();
  p->owner = this;
  p->name = name;
  p->chan_id = chan_id;
  p->spin = w->second.spin;
  request(*p);
  paths_[chan_id] = std::move(p);
}

void Paths::request(Path& p) {
  auto w = wanted_.find(p.name);
  if (w == wanted_.end()) return;
  p.tag = host_.next_tag();
  p.retry_at = 0;
  host_.request(msg::PhysRequest{p.tag, p.chan_id, w->second.kinds});
}

bool Paths::onRefused(const msg::EvError& e) {
  for (auto& [id, p] : paths_) {
    if (p->tag != e.tag) continue;
    p->tag = 0;
    ++p->failures;
    p->retry_at = retryAt(p->failures);
    // Not an error of the application's: it is relayed meanwhile. An owner that has not offered
    // its paths yet (it has just created the channel) is the usual case.
    log::info(kLogSource, "SAT-PATH-REFUSED",
              p->name + ": " + e.message + "; relayed, asking again in " +
                  std::to_string((p->retry_at - monotonicNs() + kNsPerSec / 2) / kNsPerSec) + " s");
    return true;
  }
  return false;
}

void Paths::onUnsubscribed(uint16_t chan_id) {
  auto it = paths_.find(chan_id);
  if (it == paths_.end()) return;
  closePath(*it->second);
  paths_.erase(it);
}

void Paths::closePath(Path& p) {
  p.watch = FdWatch();
  p.event_watch = FdWatch();
  if (&p == reading_) {
    retired_reader_ = std::move(p.reader);
  } else {
    p.reader.reset();
  }
  closeFd(p.fd);
  updateSpin();
}

bool Paths::alive(uint16_t chan_id, const Path* p) const {
  auto it = paths_.find(chan_id);
  return it != paths_.end() && it->second.get() == p && p->fd >= 0;
}

void Paths::onMarker(const msg::EvPhysMarker& m) {
  if (auto p = paths_.find(m.chan_id); p != paths_.end()) onMarker(*p->second, m.seq);
}

// The hub relays no more. Until now the path was left waiting (a direct socket read ahead, a
// ring not read). With the owner's message number, the path's copies of what was relayed are
// dropped and the rest delivered. Without it, what is already waiting may have been relayed as
// well: it is all dropped (a direct frame half read is dropped when complete), then the rest is
// taken; a message published during the switch can be lost that way.
void Paths::onMarker(Path& p, std::optional<uint64_t> after) {
  if (!p.open || p.marker) return;  // a marker for a path that broke since
  const uint16_t chan = p.chan_id;
  p.marker = true;
  p.after = after.value_or(UINT64_MAX);
  p.last = after.value_or(0);  // what was relayed up to the marker
  if (p.reader) {
    onPathEvent(p);
    if (alive(chan, &p)) updateSpin();
  } else {
    if (p.paused) p.watch.watch(FdWatch::readable | FdWatch::hangup);
    p.paused = false;
    onPathSocket(p, FdWatch::readable);
  }
  if (!alive(chan, &p) || after) return;
  p.drop_partial = !p.in.empty();
  p.after = 0;
}

void Paths::onPath(const msg::EvPhysPath& m) {
  auto it = paths_.find(m.chan_id);
  if (it == paths_.end() || it->second->tag != m.tag) return;
  Path& p = *it->second;
  p.tag = 0;
  p.path = m.path;
  connectPath(p, m.endpoint);
  if (p.fd < 0) return failPath(m.chan_id, "cannot connect to " + m.endpoint);
  p.hello = flow::path::encode(flow::path::Hello{1, m.path, p.name, m.token});
  auto watch = FdWatch::open(*host_.loop, p.fd, [path = &p](unsigned events) {
    path->owner->onPathSocket(*path, pathEvents(events));
  });
  if (!watch) return failPath(m.chan_id, watch.error().message);
  p.watch = std::move(*watch);
  if (p.connecting_until == 0 && !sendHello(p)) return;
  p.watch.watch((p.connecting_until != 0 ? FdWatch::writable : FdWatch::readable) |
                FdWatch::hangup);
}

bool Paths::sendHello(Path& p) {
  p.connecting_until = 0;
  if (!writeSome(p.fd, p.hello).empty()) {
    failPath(p.chan_id, "cannot send HELLO");
    return false;
  }
  p.hello.clear();
  return true;
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
    // "tcp:host:port" or "tcp:[v6]:port", as a hub address is written; a numeric host only: no
    // name lookup on the loop thread.
    const auto where = flow::Address::parse(endpoint);
    sockaddr_storage a{};
    socklen_t len = 0;
    if (!where || !numericAddress(where->host, where->port, a, len)) return;
    // Not blocking: another machine may take its time (or never answer; tick() gives up).
    int fd = ::socket(a.ss_family, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
    if (fd < 0) return;
    int one = 1;
    ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    if (::connect(fd, reinterpret_cast<sockaddr*>(&a), len) != 0) {
      if (errno != EINPROGRESS) return closeFd(fd);
      p.connecting_until = monotonicNs() + kConnectTimeoutNs;
    }
    p.fd = fd;
  }
}

void Paths::onPathSocket(Path& p, unsigned events) {
  const uint16_t chan = p.chan_id;
  if (p.connecting_until != 0) {
    if ((events & (FdWatch::writable | FdWatch::hangup)) == 0) return;
    int err = 0;
    socklen_t len = sizeof err;
    if (::getsockopt(p.fd, SOL_SOCKET, SO_ERROR, &err, &len) != 0) err = errno;
    if (err != 0) return failPath(chan, std::string("cannot connect: ") + std::strerror(err));
    if (!sendHello(p)) return;
    p.watch.watch(FdWatch::readable | FdWatch::hangup);
    return;
  }
  if ((events & (FdWatch::readable | FdWatch::hangup)) == 0) return;
  // Waiting for the marker with enough read ahead: only a hang-up wakes us.
  if (p.paused) return failPath(chan, "the owner closed the path");
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
      p.reader = std::make_unique<flow::shm::RingReader>(std::move(*reader));
      auto event = FdWatch::open(*host_.loop, p.reader->eventFd(),
                                 [path = &p](unsigned) { path->owner->onPathEvent(*path); });
      if (!event) return failPath(chan, event.error().message);
      p.event_watch = std::move(*event);
      p.event_watch.watch(FdWatch::readable);
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
    if (!p.marker && p.in.view().size() >= kMaxBeforeMarker) {
      p.paused = true;  // the rest waits in the socket (and then at the owner) for the marker
      p.watch.watch(FdWatch::hangup);
      break;
    }
    if (static_cast<size_t>(n) < want) break;
  }
  pathFrames(p);
}

void Paths::pathFrames(Path& p) {
  const uint16_t chan = p.chan_id;
  size_t used = 0;
  // Before the marker nothing is taken: the hub may still relay what comes here.
  while (p.marker) {
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
    p.last = data->seq;
    if (p.drop_partial || data->seq <= p.after) {
      p.drop_partial = false;
      ++stats_.dropped_before_marker;
      continue;
    }
    counted(p, data->payload.size());
    host_.deliver_view(chan, data->payload);
    if (!alive(chan, &p)) return;  // a slot unsubscribed, or reset the paths
    if (host_.wants_copy()) {
      host_.deliver_copy(chan, std::string(data->payload));
      if (!alive(chan, &p)) return;
    }
  }
  p.in.consume(used);
}

void Paths::onPathEvent(Path& p) {
  if (!p.reader) return;
  p.reader->drain();
  readRing(p);
}

void Paths::linger(Path& p, bool skipped) {
  const Nanos now = monotonicNs();
  const Nanos gap = now - std::exchange(p.last_read, now);
  // Only in a stream: messages that come faster than we are woken (some were skipped), or
  // soon after the one before. A message long after the last one is not followed soon.
  if (p.spin || !p.marker || (gap > kLingerNs && !skipped)) return;
  const bool started = p.linger_until == 0;
  p.linger_until = now + kLingerNs;
  if (started) updateSpin();
}

bool Paths::Path::polled() const {
  return reader && marker && (spin || linger_until != 0);
}

void Paths::updateSpin() {
  bool any = false;
  for (auto& [id, p] : paths_) {
    const bool spins = p->polled();
    if (p->reader) p->reader->setPolling(spins);  // a polled reader is not woken: no write
    any = any || spins;
  }
  if (any && !spin_) spin_ = Spinner(*host_.loop, [this] { spinOnce(); });
  if (!spin_) return;
  if (any) {
    spin_.start();
  } else {
    spin_.stop();
  }
}

// A turn of the loop with a polled ring: what is new is read without waiting for the eventfd
// (which stays watched, and is drained when it fires). A lingering ring with nothing new past its
// time is woken again.
void Paths::spinOnce() {
  std::vector<uint16_t> ready;
  bool expired = false, lingering = false;
  const Nanos now = monotonicNs();
  for (auto& [id, p] : paths_) {
    if (!p->polled()) continue;
    if (p->reader->hasNew()) {
      ready.push_back(id);
    } else if (!p->spin && p->linger_until > now) {
      lingering = true;
    } else if (!p->spin) {
      p->linger_until = 0;
      expired = true;
    }
  }
  if (expired) updateSpin();  // (a message committed meanwhile wakes it: setPolling)
  // A lingering reader is often put on its producer's CPU (it was woken from there): it lets the
  // producer run rather than spin against it.
  if (ready.empty() && lingering) sched_yield();
  for (uint16_t id : ready) {  // a callback may close any of them
    if (auto it = paths_.find(id); it != paths_.end() && it->second->reader) readRing(*it->second);
  }
}

void Paths::readRing(Path& p) {
  if (!p.marker) return;  // the latest slot is read when the marker comes
  const uint16_t chan = p.chan_id;
  // The view is the slot itself; the copy for `data` is taken under the same lease and given
  // only when the read was not torn.
  std::string copy;
  bool copied = false;
  const bool lingering = p.linger_until != 0;
  bool skipped = false;
  reading_ = &p;
  flow::shm::RingReader* reader = p.reader.get();
  const auto status = reader->readLatest([&](std::span<const std::byte> bytes, const auto& info) {
    // Skipped since the last read, or since the marker: those up to it were relayed.
    const uint64_t missed = info.seq > p.after ? std::min(info.missed, info.seq - 1 - p.after) : 0;
    stats_.missed += missed;
    p.new_missed += missed;
    skipped = missed != 0;
    if (info.seq <= p.after) {
      ++stats_.dropped_before_marker;
      return;
    }
    counted(p, bytes.size());
    if (lingering) ++stats_.polled;
    const std::string_view view(reinterpret_cast<const char*>(bytes.data()), bytes.size());
    host_.deliver_view(chan, view);
    if (alive(chan, &p) && host_.wants_copy()) copy.assign(view), copied = true;
  });
  reading_ = nullptr;
  retired_reader_.reset();
  if (status == flow::shm::ReadStatus::torn) {
    ++stats_.torn;
  } else if (copied) {
    host_.deliver_copy(chan, std::move(copy));
  }
  // More may follow soon (a stream): polled a while, it is read without a wake-up.
  if (status != flow::shm::ReadStatus::nothing_new && alive(chan, &p)) linger(p, skipped);
}

void Paths::counted(Path& p, size_t bytes) {
  ++stats_.path_messages;
  ++p.new_messages;
  p.new_bytes += bytes;
}

void Paths::report(Path& p) {
  if (p.new_messages == 0 && p.new_missed == 0) return;
  if (host_.hub_minor() >= 10) {
    host_.received(msg::PhysReceived{p.chan_id, p.new_messages, p.new_bytes, p.new_missed});
  }
  p.new_messages = p.new_bytes = p.new_missed = 0;
}

void Paths::failPath(uint16_t chan_id, const std::string& why) {
  auto it = paths_.find(chan_id);
  if (it == paths_.end()) return;
  Path& p = *it->second;
  const bool was_open = p.open;
  // A direct path that carried our messages: the owner (1.11) replays what it lost (PHYS_FALLBACK).
  const bool resume = p.open && p.marker && p.path == msg::kPhysDirect && host_.hub_minor() >= 11;
  const uint64_t last = p.last;
  report(p);
  closePath(p);
  p.in.clear();
  p.open = false;
  p.marker = false;
  p.after = 0;
  p.last = 0;
  p.drop_partial = false;
  p.paused = false;
  p.linger_until = 0;
  p.last_read = 0;
  p.tag = 0;
  p.connecting_until = 0;
  p.hello.clear();
  ++p.failures;
  ++stats_.fallbacks;
  p.retry_at = retryAt(p.failures);
  if (resume) {
    host_.fallback(msg::PhysFallback{chan_id, last});
  } else if (was_open) {
    host_.state(msg::PhysState{chan_id, 0});  // relayed again
  }
  log::warn(kLogSource, "SAT-PATH-FALLBACK",
            p.name + ": " + why + "; relayed by the hub meanwhile");
}

}  // namespace skr::flow::phys
