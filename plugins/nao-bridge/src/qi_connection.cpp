// SPDX-License-Identifier: Apache-2.0
#include "qi_connection.h"

#include <arpa/inet.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <charconv>
#include <chrono>
#include <cstring>

namespace skr::nao::qi {

std::int64_t monotonicNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

int msLeft(std::int64_t deadline_ns) {
  const std::int64_t left = (deadline_ns - monotonicNs()) / 1'000'000;
  return left < 0 ? 0 : static_cast<int>(left > 60'000 ? 60'000 : left);
}

namespace {

Error sysError(const std::string& what) {
  return makeError(Errc::io_error, what + ": " + std::strerror(errno));
}

}  // namespace

std::string Endpoint::text() const {
  const bool v6 = host.find(':') != std::string::npos;
  return (v6 ? "[" + host + "]" : host) + ":" + std::to_string(port);
}

Result<Endpoint> parseEndpoint(std::string_view url) {
  constexpr std::string_view kTcp = "tcp://";
  const auto scheme = url.find("://");
  if (scheme == std::string_view::npos) {
    return makeError(Errc::invalid_argument, "endpoint " + std::string(url) + ": no scheme");
  }
  if (url.substr(0, kTcp.size()) != kTcp) {
    return makeError(Errc::unsupported,
                     "endpoint " + std::string(url) + ": only tcp:// is supported");
  }
  std::string_view rest = url.substr(kTcp.size());
  if (const auto slash = rest.find('/'); slash != std::string_view::npos)
    rest = rest.substr(0, slash);
  Endpoint e;
  std::string_view port;
  if (!rest.empty() && rest[0] == '[') {
    const auto close = rest.find(']');
    if (close == std::string_view::npos || close + 1 >= rest.size() || rest[close + 1] != ':') {
      return makeError(Errc::invalid_argument, "endpoint " + std::string(url) + ": bad host");
    }
    e.host = std::string(rest.substr(1, close - 1));
    port = rest.substr(close + 2);
  } else {
    const auto colon = rest.rfind(':');
    if (colon == std::string_view::npos || colon == 0) {
      return makeError(Errc::invalid_argument, "endpoint " + std::string(url) + ": no port");
    }
    e.host = std::string(rest.substr(0, colon));
    port = rest.substr(colon + 1);
  }
  unsigned p = 0;
  const auto [end, ec] = std::from_chars(port.data(), port.data() + port.size(), p);
  if (ec != std::errc() || end != port.data() + port.size() || p == 0 || p > 65535) {
    return makeError(Errc::invalid_argument, "endpoint " + std::string(url) + ": bad port");
  }
  e.port = static_cast<std::uint16_t>(p);
  return e;
}

bool isLoopback(std::string_view host) noexcept {
  return host.substr(0, 4) == "127." || host == "::1" || host == "localhost";
}

QiConnection::QiConnection(QiConnection&& o) noexcept
    : fd_(o.fd_),
      to_(std::move(o.to_)),
      max_payload_(o.max_payload_),
      framer_(std::move(o.framer_)) {
  o.fd_ = -1;
}

QiConnection& QiConnection::operator=(QiConnection&& o) noexcept {
  if (this != &o) {
    close();
    fd_ = o.fd_;
    o.fd_ = -1;
    to_ = std::move(o.to_);
    max_payload_ = o.max_payload_;
    framer_ = std::move(o.framer_);
  }
  return *this;
}

void QiConnection::close() noexcept {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
}

Result<QiConnection> QiConnection::dial(const Endpoint& to, int timeout_ms,
                                        std::uint32_t max_payload) {
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  addrinfo* list = nullptr;
  const std::string where = to.text();
  const int gai = ::getaddrinfo(to.host.c_str(), std::to_string(to.port).c_str(), &hints, &list);
  if (gai != 0) return makeError(Errc::io_error, "resolve " + to.host + ": " + ::gai_strerror(gai));
  Error last = makeError(Errc::io_error, "no address for " + to.host);
  const std::int64_t deadline = monotonicNs() + std::int64_t{timeout_ms} * 1'000'000;
  for (addrinfo* a = list; a != nullptr; a = a->ai_next) {
    const int fd = ::socket(a->ai_family, a->ai_socktype | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
    if (fd < 0) {
      last = sysError("socket");
      continue;
    }
    if (::connect(fd, a->ai_addr, a->ai_addrlen) != 0 && errno != EINPROGRESS) {
      last = sysError("connect " + where);
      ::close(fd);
      continue;
    }
    pollfd p{fd, POLLOUT, 0};
    const int n = ::poll(&p, 1, msLeft(deadline));
    int err = 0;
    socklen_t len = sizeof(err);
    if (n <= 0) {
      last = makeError(Errc::timeout, "connect " + where + ": timed out");
    } else if (::getsockopt(fd, SOL_SOCKET, SO_ERROR, &err, &len) != 0 || err != 0) {
      errno = err;
      last = sysError("connect " + where);
    } else {
      const int one = 1;
      ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof(one));
      ::freeaddrinfo(list);
      QiConnection c;
      c.fd_ = fd;
      c.to_ = to;
      c.max_payload_ = max_payload;
      c.framer_ = MessageFramer(max_payload);
      return c;
    }
    ::close(fd);
  }
  ::freeaddrinfo(list);
  return last;
}

Result<void> QiConnection::write(const std::string& bytes) {
  if (fd_ < 0) return makeError(Errc::closed, "not connected");
  const std::int64_t deadline = monotonicNs() + 2'000'000'000;
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::send(fd_, bytes.data() + done, bytes.size() - done, MSG_NOSIGNAL);
    if (n > 0) {
      done += static_cast<std::size_t>(n);
      continue;
    }
    if (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR) {
      Error e = sysError("send to " + to_.text());
      close();
      return e;
    }
    pollfd p{fd_, POLLOUT, 0};
    if (::poll(&p, 1, msLeft(deadline)) <= 0) {
      close();
      return makeError(Errc::timeout, "send to " + to_.text() + ": the robot does not read");
    }
  }
  return {};
}

Result<void> QiConnection::read(std::vector<Message>& out) {
  if (fd_ < 0) return makeError(Errc::closed, "not connected");
  char buf[16384];
  for (;;) {
    const ssize_t got = ::recv(fd_, buf, sizeof(buf), 0);
    if (got > 0) {
      framer_.append(std::string_view(buf, static_cast<std::size_t>(got)));
      if (static_cast<std::size_t>(got) < sizeof(buf)) break;
      if (framer_.buffered() > max_payload_ + kHeaderSize) break;  // frame it first
      continue;
    }
    if (got < 0 && (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR)) break;
    Error e = got == 0
                  ? makeError(Errc::closed, "connection closed by the robot (" + to_.text() + ")")
                  : sysError("recv from " + to_.text());
    close();
    return e;
  }
  for (;;) {
    auto m = framer_.next();
    if (!m) {
      close();
      return makeError(Errc::protocol_error, "QI-PROTOCOL " + m.error().message);
    }
    if (!m.value()) return {};
    out.push_back(std::move(*m.value()));
  }
}

}  // namespace skr::nao::qi
