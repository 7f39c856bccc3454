// SPDX-License-Identifier: Apache-2.0
// Internals of physical mode (paths.h): the state of served channels, peers and
// paths, and the socket helpers that paths_owner.cpp and paths_subscriber.cpp share.
#pragma once

#include "in_buffer.h"
#include "paths.h"

#include <skrobot/runtime/flow/path_framing.h>
#include <skrobot/runtime/log.h>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/uio.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <deque>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>

namespace skr::flow::phys {
namespace paths_io {

// Both sides log as the satellite library (tag SAT-PATH), a module's paths in the hub too.
inline constexpr const char* kLogSource = "satellite";
inline constexpr uint32_t kMaxDataFrame = flow::path::kMaxDataBytes + 32;
inline constexpr size_t kMaxPeerQueue = 16u << 20;  // a direct subscriber's backlog; beyond: drops
// What a direct subscriber reads ahead while its marker is on its way; then the socket waits.
inline constexpr size_t kMaxBeforeMarker = 16u << 20;
inline constexpr Nanos kRetryMinNs = kNsPerSec, kRetryMaxNs = 30 * kNsPerSec;
inline constexpr Nanos kConnectTimeoutNs = 5 * kNsPerSec;  // a TCP path's connect
// When to ask again for a path after `failures` (from 1) in a row: 1 s, doubling to 30 s.
inline Nanos retryAt(int failures) {
  return monotonicNs() + std::min(kRetryMaxNs, kRetryMinNs << std::clamp(failures - 1, 0, 5));
}

// What a path socket's watch reports to onPeer/onPathSocket: a failed poll counts as a hang-up.
inline unsigned pathEvents(unsigned events) {
  return (events & FdWatch::error) != 0 ? unsigned(FdWatch::hangup) : events;
}
inline void closeFd(int& fd) {
  if (fd >= 0) ::close(fd);
  fd = -1;
}

// A numeric IPv4 or IPv6 address and a port as a socket address (no name lookup: callers are on
// the loop thread). False when `host` is not numeric.
inline bool numericAddress(const std::string& host, uint16_t port, sockaddr_storage& out,
                           socklen_t& len) {
  out = {};
  auto* v4 = reinterpret_cast<sockaddr_in*>(&out);
  auto* v6 = reinterpret_cast<sockaddr_in6*>(&out);
  if (::inet_pton(AF_INET, host.c_str(), &v4->sin_addr) == 1) {
    v4->sin_family = AF_INET;
    v4->sin_port = htons(port);
    len = sizeof *v4;
    return true;
  }
  if (::inet_pton(AF_INET6, host.c_str(), &v6->sin6_addr) == 1) {
    v6->sin6_family = AF_INET6;
    v6->sin6_port = htons(port);
    len = sizeof *v6;
    return true;
  }
  return false;
}

// Writes `head` then `body` with one system call where they fit (a frame's reader is woken once,
// not once for its header and again for its payload), or what fits: how many of their bytes went.
inline size_t writeSome(int fd, std::string_view head, std::string_view body) {
  const size_t total = head.size() + body.size();
  size_t done = 0;
  while (done < total) {
    iovec iov[2];
    int n = 0;
    if (done < head.size()) iov[n++] = {const_cast<char*>(head.data()) + done, head.size() - done};
    const size_t in_body = done > head.size() ? done - head.size() : 0;
    iov[n++] = {const_cast<char*>(body.data()) + in_body, body.size() - in_body};
    msghdr m{};
    m.msg_iov = iov;
    m.msg_iovlen = static_cast<size_t>(n);
    const ssize_t w = ::sendmsg(fd, &m, MSG_NOSIGNAL);
    if (w < 0) {
      if (errno == EINTR) continue;
      break;  // EAGAIN, or an error the read side will see
    }
    done += static_cast<size_t>(w);
  }
  return done;
}

// Writes all of `bytes` on a non-blocking socket, or what fits; the rest is returned.
inline std::string_view writeSome(int fd, std::string_view bytes) {
  return bytes.substr(writeSome(fd, {}, bytes));
}

}  // namespace paths_io

struct Paths::Served {
  uint16_t chan_id = 0;
  std::string name;
  uint8_t paths = 0;
  std::optional<flow::shm::RingWriter> ring;
  bool relay_needed = true;
  uint64_t seq = 0;
  // Sent on direct paths, kept for a fallback (kKeptBytes): by seq, while a direct path is
  // served or until keep_until.
  std::deque<std::pair<uint64_t, std::string>> kept;
  std::vector<std::string> spare;  // buffers of messages no longer kept, to keep the next ones in
  size_t kept_bytes = 0;
  Nanos keep_until = 0;
  uint64_t unrelayed_messages = 0, unrelayed_bytes = 0;  // for PHYS_COUNT
};

struct Paths::Peer {
  Paths* owner = nullptr;
  int fd = -1;
  FdWatch watch;  // destroyed before fd is closed
  std::string in, out;
  uint8_t path = 0;  // 0 until WELCOME
  uint16_t chan_id = 0;
  uint32_t subscriber = 0;
  uint32_t lease = 0;
  bool tcp = false;           // came through the TCP listener: direct paths only
  std::string pending_hello;  // a HELLO whose grant has not come yet, until pending_until
  std::string pending_token;  // its token
  Nanos pending_until = 0;
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
  FdWatch watch;        // the socket; destroyed before fd is closed
  FdWatch event_watch;  // a ring's eventfd (shared memory), destroyed before the reader
  std::unique_ptr<flow::shm::RingReader> reader;  // kept in place while a callback reads
  InBuffer in;
  bool open = false;           // WELCOME came
  Nanos connecting_until = 0;  // a TCP connect in progress (HELLO waits in `hello`) until then
  std::string hello;
  bool marker = false;        // the hub relays no more: what comes on the path is ours
  uint64_t after = 0;         // from the marker: path messages up to this one were relayed
  uint64_t last = 0;          // direct: the number of the last message we have (for a fallback)
  bool drop_partial = false;  // the direct frame being read began before a marker without `after`
  bool paused = false;        // before the marker, kMaxBeforeMarker read: reading waits for it
  bool spin = false;          // a ring polled on each turn of the loop (PathWait::spin)
  Nanos linger_until = 0;     // a woken ring polled until then after its last message (0: not)
  Nanos last_read = 0;        // when a message last came from the ring
  Nanos retry_at = 0;         // 0: not waiting to ask again
  int failures = 0;
  // Whether the ring is read from the loop's idle turns now (spinning, or lingering).
  [[nodiscard]] bool polled() const;
  uint64_t new_messages = 0, new_bytes = 0, new_missed = 0;  // not reported yet (PHYS_RECEIVED)
};

}  // namespace skr::flow::phys
