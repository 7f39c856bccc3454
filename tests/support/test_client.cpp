// SPDX-License-Identifier: Apache-2.0
#include "test_client.h"

#include "skr_line.h"
#include "skr_udp.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <vector>

namespace skr::test {

TestClient::~TestClient() {
  close();
}

struct TestClient::Line {
  std::vector<uint8_t> buf = std::vector<uint8_t>(70000);
  skr_line_rx rx{};
  Line() { skr_line_rx_init(&rx, buf.data(), buf.size()); }
};

TestClient TestClient::overLine(int fd) {
  TestClient c(fd);
  c.line_ = std::make_shared<Line>();
  return c;
}

bool TestClient::sendLineBytes(std::string_view bytes) {
  while (!bytes.empty()) {
    const ssize_t n = ::write(fd_, bytes.data(), bytes.size());
    if (n < 0) {
      if (errno == EINTR) continue;
      if (errno == EAGAIN) {
        pollfd p{fd_, POLLOUT, 0};
        (void)::poll(&p, 1, 1000);
        continue;
      }
      return false;
    }
    bytes.remove_prefix(static_cast<size_t>(n));
  }
  return true;
}

Result<TestClient> TestClient::overUdp(const std::string& host, uint16_t port,
                                       const std::string& user,
                                       const std::array<uint8_t, 16>& key) {
  auto u = std::make_shared<skr_udp>();
  if (skr_udp_open(u.get(), host.c_str(), port, user.c_str(), key.data(), 3000) != 0) {
    return makeError(Errc::io_error, "no UDP session with " + host + ":" + std::to_string(port));
  }
  TestClient c(u->fd);
  c.udp_ = std::move(u);
  return c;
}

skr_udp* TestClient::udp() const noexcept {
  return udp_.get();
}

TestClient::TestClient(TestClient&& o) noexcept
    : fd_(o.fd_),
      buf_(std::move(o.buf_)),
      skipped_(std::move(o.skipped_)),
      line_(std::move(o.line_)),
      udp_(std::move(o.udp_)) {
  o.fd_ = -1;
}

TestClient& TestClient::operator=(TestClient&& o) noexcept {
  if (this != &o) {
    close();
    fd_ = o.fd_;
    o.fd_ = -1;
    buf_ = std::move(o.buf_);
    skipped_ = std::move(o.skipped_);
    line_ = std::move(o.line_);
    udp_ = std::move(o.udp_);
  }
  return *this;
}

void TestClient::close() {
  if (udp_ && fd_ >= 0) {
    skr_udp_close(udp_.get());  // sends CLOSE and closes the socket
    fd_ = -1;
  }
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
}

Result<TestClient> TestClient::connectUnix(const std::string& path) {
  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  std::strncpy(addr.sun_path, path.c_str(), sizeof(addr.sun_path) - 1);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
    const int e = errno;
    ::close(fd);
    return makeError(Errc::io_error, "connect " + path + ": " + std::strerror(e));
  }
  return TestClient(fd);
}

Result<TestClient> TestClient::connectTcp(const std::string& host, uint16_t port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(port);
  inet_pton(AF_INET, host.c_str(), &addr.sin_addr);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
    const int e = errno;
    ::close(fd);
    return makeError(Errc::io_error, "connect " + host + ": " + std::strerror(e));
  }
  int one = 1;
  setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
  return TestClient(fd);
}

bool TestClient::sendRaw(std::string_view bytes) {
  if (udp_) {
    while (bytes.size() >= 4) {
      uint32_t len = 0;
      std::memcpy(&len, bytes.data(), 4);
      const size_t n = std::min(bytes.size(), 4 + static_cast<size_t>(len));
      if (skr_udp_send(udp_.get(), reinterpret_cast<const uint8_t*>(bytes.data()), n) != 0) {
        return false;
      }
      bytes.remove_prefix(n);
    }
    return true;
  }
  if (line_) {
    std::string wire;
    while (bytes.size() >= 4) {
      uint32_t len = 0;
      std::memcpy(&len, bytes.data(), 4);
      const size_t n = std::min(bytes.size(), 4 + static_cast<size_t>(len));
      std::vector<uint8_t> out(n + SKR_LINE_OVERHEAD(n));
      const size_t w = skr_line_encode(reinterpret_cast<const uint8_t*>(bytes.data()), n,
                                       out.data(), out.size());
      wire.append(reinterpret_cast<const char*>(out.data()), w);
      bytes.remove_prefix(n);
    }
    return sendLineBytes(wire);
  }
  while (!bytes.empty()) {
    const ssize_t n = ::send(fd_, bytes.data(), bytes.size(), MSG_NOSIGNAL);
    if (n < 0) {
      if (errno == EINTR) continue;
      return false;
    }
    bytes.remove_prefix(static_cast<size_t>(n));
  }
  return true;
}

bool TestClient::fill(int timeout_ms) {
  if (udp_) {
    const uint8_t* frame = nullptr;
    size_t n = 0;
    if (skr_udp_poll(udp_.get(), timeout_ms, &frame, &n) != 1) return false;
    buf_.append(reinterpret_cast<const char*>(frame), n);
    return true;
  }
  pollfd p{fd_, POLLIN, 0};
  if (::poll(&p, 1, timeout_ms) <= 0) return false;
  char tmp[65536];
  const ssize_t n = line_ ? ::read(fd_, tmp, sizeof tmp) : ::recv(fd_, tmp, sizeof tmp, 0);
  if (n <= 0) return false;
  if (!line_) {
    buf_.append(tmp, static_cast<size_t>(n));
    return true;
  }
  for (ssize_t i = 0; i < n; ++i) {
    const size_t len = skr_line_rx_byte(&line_->rx, static_cast<uint8_t>(tmp[i]));
    if (len != 0) buf_.append(reinterpret_cast<const char*>(skr_line_rx_frame(&line_->rx)), len);
  }
  return true;
}

std::optional<Frame> TestClient::readFrame(int timeout_ms) {
  for (;;) {
    if (buf_.size() >= 5) {
      uint32_t len = 0;
      std::memcpy(&len, buf_.data(), 4);
      if (buf_.size() >= 4 + static_cast<size_t>(len)) {
        Frame f;
        f.code = static_cast<uint8_t>(buf_[4]);
        f.body = buf_.substr(5, len - 1);
        buf_.erase(0, 4 + static_cast<size_t>(len));
        return f;
      }
    }
    if (fd_ < 0 || !fill(timeout_ms)) return std::nullopt;
  }
}

std::optional<Frame> TestClient::recv(int timeout_ms) {
  if (!skipped_.empty()) {
    Frame f = std::move(skipped_.front());
    skipped_.pop_front();
    return f;
  }
  return readFrame(timeout_ms);
}

std::optional<Frame> TestClient::waitFor(flow::Code code, int timeout_ms) {
  for (auto it = skipped_.begin(); it != skipped_.end(); ++it) {
    if (it->kind() == code) {
      Frame f = std::move(*it);
      skipped_.erase(it);
      return f;
    }
  }
  for (;;) {
    auto f = readFrame(timeout_ms);
    if (!f) return std::nullopt;
    if (f->kind() == code) return f;
    skipped_.push_back(std::move(*f));
  }
}

std::optional<Frame> TestClient::recvReply(int timeout_ms) {
  for (;;) {
    auto f = recv(timeout_ms);
    if (!f) return f;
    if (f->kind() == flow::Code::reply_ok || f->kind() == flow::Code::reply_error) return f;
  }
}

bool TestClient::closedByPeer(int timeout_ms) {
  for (;;) {
    pollfd p{fd_, POLLIN, 0};
    if (::poll(&p, 1, timeout_ms) <= 0) return false;
    char tmp[4096];
    const ssize_t n = ::recv(fd_, tmp, sizeof tmp, 0);
    if (n == 0) return true;
    if (n < 0) return errno == ECONNRESET;
  }
}

Result<flow::msg::LoginOk> TestClient::login(const std::string& user, const std::string& password,
                                             flow::ValueEncoding enc, uint16_t minor) {
  flow::msg::Login m;
  m.minor = minor;
  m.value_encoding = static_cast<uint8_t>(enc);
  m.user = user;
  m.password = password;
  m.client_name = "test";
  auto reply = call(m);
  if (!reply) return makeError(Errc::timeout, "no reply to LOGIN");
  if (reply->kind() == flow::Code::reply_error) {
    auto e = flow::decode<flow::msg::ReplyError>(reply->body);
    return makeError(Errc::permission_denied, e ? e->message : "bad REPLY_ERROR");
  }
  auto ok = flow::decode<flow::msg::LoginOk>(reply->body);
  if (!ok) return ok.error();
  return std::move(ok).value();
}

Result<flow::msg::LoginOk> TestClient::loginFlow(const std::string& user,
                                                 const std::string& password) {
  auto r = login(user, password);
  if (!r) return r;
  auto reply = call(flow::msg::Empty<flow::Code::go_async>{});
  if (!reply || reply->kind() != flow::Code::reply_ok) {
    return makeError(Errc::protocol_error, "GO_ASYNC refused");
  }
  return r;
}

}  // namespace skr::test
