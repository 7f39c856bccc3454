// SPDX-License-Identifier: Apache-2.0
#include "posix_socket.h"

#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <sys/uio.h>
#include <sys/un.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

namespace skr::sat::detail {
namespace {

Error noHub(const Address& a, const std::string& why) {
  return makeError(Errc::io_error,
                   "no hub at " + a.toString() + ": is skrobot running? (" + why + ")");
}

// Non-blocking connect bounded by timeout_ms; leaves the fd blocking again. Returns 0 or errno.
int connectWithin(int fd, const sockaddr* addr, socklen_t len, uint32_t timeout_ms) {
  const int flags = fcntl(fd, F_GETFL);
  fcntl(fd, F_SETFL, flags | O_NONBLOCK);
  int err = 0;
  if (::connect(fd, addr, len) != 0) {
    err = errno;
    if (err == EINPROGRESS) {
      pollfd p{fd, POLLOUT, 0};
      const int n = ::poll(&p, 1, static_cast<int>(timeout_ms));
      if (n <= 0) {
        err = n == 0 ? ETIMEDOUT : errno;
      } else {
        socklen_t sl = sizeof err;
        getsockopt(fd, SOL_SOCKET, SO_ERROR, &err, &sl);
      }
    }
  }
  fcntl(fd, F_SETFL, flags);
  return err;
}

}  // namespace

Result<int> connectSocket(const Address& a, uint32_t timeout_ms) {
  if (a.kind == Address::Kind::serial || a.kind == Address::Kind::udp) {
    // The line carries one session: a second connection would end the flow's. A UDP session
    // carries frames of one datagram and may lose them: no place for blocking requests.
    return makeError(Errc::unsupported,
                     std::string(a.kind == Address::Kind::serial ? "a serial:" : "a udp:") +
                         " address carries one session, the flow; synchronous requests need a "
                         "local:, tcp: or tls: address");
  }
  if (a.kind == Address::Kind::local) {
    const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
    if (fd < 0) return makeError(Errc::io_error, std::string("socket: ") + std::strerror(errno));
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    std::strncpy(addr.sun_path, a.path.c_str(), sizeof(addr.sun_path) - 1);
    if (int err = connectWithin(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr, timeout_ms)) {
      ::close(fd);
      return noHub(a, std::string("connect: ") + std::strerror(err));
    }
    return fd;
  }
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  addrinfo* list = nullptr;
  const std::string port = std::to_string(a.port);
  if (int rc = getaddrinfo(a.host.c_str(), port.c_str(), &hints, &list); rc != 0) {
    return noHub(a, std::string("resolve: ") + gai_strerror(rc));
  }
  std::string why = "no address";
  for (addrinfo* ai = list; ai != nullptr; ai = ai->ai_next) {
    const int fd = ::socket(ai->ai_family, ai->ai_socktype | SOCK_CLOEXEC, ai->ai_protocol);
    if (fd < 0) continue;
    if (int err = connectWithin(fd, ai->ai_addr, ai->ai_addrlen, timeout_ms); err != 0) {
      why = std::string("connect: ") + std::strerror(err);
      ::close(fd);
      continue;
    }
    int one = 1;
    setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    freeaddrinfo(list);
    return fd;
  }
  freeaddrinfo(list);
  return noHub(a, why);
}

namespace {

// Writes `bytes` then `more`, gathered (no copy of them into one buffer).
Result<void> sendRaw(int fd, std::string_view bytes, std::string_view more = {}) {
  while (!bytes.empty() || !more.empty()) {
    iovec iov[2] = {{const_cast<char*>(bytes.data()), bytes.size()},
                    {const_cast<char*>(more.data()), more.size()}};
    msghdr m{};
    m.msg_iov = bytes.empty() ? iov + 1 : iov;
    m.msg_iovlen = bytes.empty() || more.empty() ? 1 : 2;
    ssize_t n = ::sendmsg(fd, &m, MSG_NOSIGNAL);
    if (n < 0) {
      if (errno == EINTR) continue;
      return makeError(Errc::closed, std::string("send: ") + std::strerror(errno));
    }
    const size_t first = std::min(static_cast<size_t>(n), bytes.size());
    bytes.remove_prefix(first);
    more.remove_prefix(static_cast<size_t>(n) - first);
  }
  return {};
}

Result<size_t> readRaw(int fd, char* dst, size_t room, uint32_t timeout_ms) {
  // As much as has arrived, up to `room`: a file's chunk takes a few calls instead of one per
  // 64 KiB. Poll only when nothing is there yet (FIONREAD).
  for (;;) {
    int ready = 0;
    if (::ioctl(fd, FIONREAD, &ready) != 0) ready = 0;
    if (ready > 0) {
      const ssize_t got = ::recv(fd, dst, room, 0);
      if (got > 0) return static_cast<size_t>(got);
      if (got < 0 && errno == EINTR) continue;
      if (got == 0) return makeError(Errc::closed, "the hub closed the connection");
      return makeError(Errc::closed, std::string("recv: ") + std::strerror(errno));
    }
    pollfd p{fd, POLLIN, 0};
    const int n = ::poll(&p, 1, static_cast<int>(timeout_ms));
    if (n < 0 && errno == EINTR) continue;
    if (n == 0)
      return makeError(Errc::timeout, "no reply within " + std::to_string(timeout_ms) + " ms");
    if (n < 0) return makeError(Errc::io_error, std::string("poll: ") + std::strerror(errno));
    // Readable with nothing to read: the hub closed the connection (or it failed).
    if (::ioctl(fd, FIONREAD, &ready) != 0 || ready == 0) {
      char probe;
      const ssize_t got = ::recv(fd, &probe, 1, MSG_PEEK | MSG_DONTWAIT);
      if (got == 0) return makeError(Errc::closed, "the hub closed the connection");
      if (got < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR) {
        return makeError(Errc::closed, std::string("recv: ") + std::strerror(errno));
      }
    }
  }
}

// Appends what has arrived (ciphertext, or a handshake's reply) to `buf`.
Result<void> readRawAppend(int fd, std::string& buf, uint32_t timeout_ms) {
  constexpr size_t kChunk = 64 << 10;
  const size_t had = buf.size();
  buf.resize(had + kChunk);
  auto got = readRaw(fd, buf.data() + had, kChunk, timeout_ms);
  buf.resize(had + (got ? *got : 0));
  if (!got) return got.error();
  return {};
}

}  // namespace

Result<void> sendAll(int fd, flow::TlsSession* tls, std::string_view bytes, std::string_view more) {
  if (tls == nullptr) return sendRaw(fd, bytes, more);
  if (auto w = tls->write(bytes); !w) return makeError(Errc::closed, w.error().message);
  if (!more.empty()) {
    if (auto w = tls->write(more); !w) return makeError(Errc::closed, w.error().message);
  }
  std::string cipher;
  tls->takeOutput(cipher);
  return sendRaw(fd, cipher);
}

Result<size_t> readSome(int fd, flow::TlsSession* tls, char* dst, size_t room,
                        uint32_t timeout_ms) {
  if (tls == nullptr) return readRaw(fd, dst, room, timeout_ms);
  for (;;) {
    size_t filled = 0;
    while (filled < room) {
      auto got = tls->read(dst + filled, room - filled);
      if (!got) return makeError(Errc::closed, got.error().message);
      if (*got == 0) break;
      filled += *got;
    }
    if (filled > 0) return filled;
    std::string cipher;
    if (auto r = readRawAppend(fd, cipher, timeout_ms); !r) return r.error();
    if (auto r = tls->receive(cipher); !r) return makeError(Errc::closed, r.error().message);
    if (tls->hasOutput()) {  // a key update or the like
      std::string out;
      tls->takeOutput(out);
      if (auto s = sendRaw(fd, out); !s) return s.error();
    }
  }
}

Result<flow::TlsSession> tlsHandshake(int fd, const flow::TlsContext& context,
                                      const Address& address, uint32_t timeout_ms) {
  const auto failed = [&](const std::string& why) {
    return makeError(Errc::io_error, "TLS with " + address.toString() + ": " + why);
  };
  auto session = flow::TlsSession::open(context, address.host);
  if (!session) return failed(session.error().message);
  flow::TlsSession& tls = *session;
  for (;;) {
    std::string out;
    tls.takeOutput(out);
    if (auto s = sendRaw(fd, out); !s) return failed(s.error().message);
    if (tls.established()) return std::move(session).value();
    std::string cipher;
    if (auto r = readRawAppend(fd, cipher, timeout_ms); !r) {
      if (r.error().code == Errc::closed) {
        return failed(
            "the hub closed the connection during the handshake (is its TCP port "
            "plain? then use a tcp: address)");
      }
      return failed(r.error().message);
    }
    if (auto r = tls.receive(cipher); !r) {
      std::string alert;
      tls.takeOutput(alert);
      (void)sendRaw(fd, alert);
      return failed(r.error().message);
    }
  }
}

void closeTls(int fd, flow::TlsSession& tls) noexcept {
  tls.shutdown();
  std::string out;
  tls.takeOutput(out);
  if (!out.empty()) (void)::send(fd, out.data(), out.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
}

}  // namespace skr::sat::detail
