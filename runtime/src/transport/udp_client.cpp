// SPDX-License-Identifier: Apache-2.0
// A client's UDP session (udp_client.h).
#include "udp_client.h"

#include <skrobot/runtime/clock.h>
#include <skrobot/runtime/flow/udp.h>
#include <skrobot/runtime/log.h>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/random.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>

namespace skr::flow::transport {
namespace {

constexpr Nanos kResendNs = 200 * kNsPerMs;  // as the board's skr_udp_open
// Frames a paused session may have waiting.
constexpr size_t kPendingBytes = 256u << 10;
// Datagrams read per readiness event, so that a flood does not hold the loop.
constexpr int kReadsPerWake = 256;

std::string numericText(const sockaddr_storage& a) {
  char host[INET6_ADDRSTRLEN] = "?";
  if (a.ss_family == AF_INET) {
    const auto* v4 = reinterpret_cast<const sockaddr_in*>(&a);
    ::inet_ntop(AF_INET, &v4->sin_addr, host, sizeof host);
    return std::string(host) + ":" + std::to_string(ntohs(v4->sin_port));
  }
  const auto* v6 = reinterpret_cast<const sockaddr_in6*>(&a);
  ::inet_ntop(AF_INET6, &v6->sin6_addr, host, sizeof host);
  return "[" + std::string(host) + "]:" + std::to_string(ntohs(v6->sin6_port));
}

int hexDigit(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

}  // namespace

Result<UdpKey> parseUdpKey(std::string_view hex) {
  const auto space = [](char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r'; };
  while (!hex.empty() && space(hex.front())) hex.remove_prefix(1);
  while (!hex.empty() && space(hex.back())) hex.remove_suffix(1);
  UdpKey key{};
  if (hex.size() != 2 * key.size()) {
    return makeError(Errc::invalid_argument,
                     "a UDP key is 32 hex digits (as `skrobot user key NAME` prints it), not " +
                         std::to_string(hex.size()) + " characters");
  }
  for (size_t i = 0; i < key.size(); ++i) {
    const int hi = hexDigit(hex[2 * i]);
    const int lo = hexDigit(hex[2 * i + 1]);
    if (hi < 0 || lo < 0) {
      return makeError(Errc::invalid_argument,
                       "a UDP key is 32 hex digits: it has another character");
    }
    key[i] = static_cast<uint8_t>(hi * 16 + lo);
  }
  return key;
}

Result<UdpKey> readUdpKeyFile(const std::string& path) {
  std::ifstream in(path);
  if (!in) {
    return makeError(errno == ENOENT ? Errc::not_found : Errc::io_error,
                     "UDP key file " + path + ": " + std::strerror(errno));
  }
  std::ostringstream text;
  text << in.rdbuf();
  auto key = parseUdpKey(text.str());
  if (!key) return makeError(key.error().code, "UDP key file " + path + ": " + key.error().message);
  return key;
}

Result<std::unique_ptr<UdpClientSession>> UdpClientSession::open(Loop& loop,
                                                                 const sockaddr_storage& to,
                                                                 socklen_t to_len,
                                                                 const DialOptions& options) {
  const int fd = ::socket(to.ss_family, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (fd < 0) return makeError(Errc::io_error, std::string("socket: ") + std::strerror(errno));
  if (::connect(fd, reinterpret_cast<const sockaddr*>(&to), to_len) != 0) {
    const int err = errno;
    ::close(fd);
    return makeError(Errc::io_error, "connect " + numericText(to) + ": " + std::strerror(err));
  }
  PeerIdentity peer;
  peer.kind = TransportKind::udp;
  peer.address = numericText(to);
  peer.account = options.udp_user;
  auto s = std::make_unique<UdpClientSession>(loop, fd, std::move(peer), options);
  auto w = FdWatch::open(loop, fd, [p = s.get()](unsigned events) { p->onEvents(events); });
  if (!w) return w.error();
  s->watch_ = std::move(w).value();
  return s;
}

UdpClientSession::UdpClientSession(Loop& loop, int fd, PeerIdentity peer,
                                   const DialOptions& options)
    : MessageSession(loop, TransportKind::udp, std::move(peer),
                     options.udp_max_datagram - SKR_UDP_DATA_OVERHEAD, kPendingBytes,
                     "the UDP session ended"),
      fd_(fd),
      user_(options.udp_user),
      handshake_ms_(options.udp_handshake_ms),
      max_datagram_(options.udp_max_datagram),
      silence_ms_(options.udp_silence_ms),
      tx_(std::max<size_t>(options.udp_max_datagram, 256)),
      resend_(loop, [this] { resend(); }),
      deadline_(loop,
                [this] {
                  const std::string waited = " within " + std::to_string(handshake_ms_) + " ms";
                  handshakeOver(TransportEnd{
                      TransportEnd::Why::error,
                      cookie_seen_ ? "the hub answered the HELLO but not the OPEN" + waited +
                                         ": the key is not account \"" + user_ +
                                         "\"'s (skrobot user key " + user_ + "), or it has none"
                                   : "no answer to the UDP handshake" + waited +
                                         " (is the hub's server.udp on at that address?)"});
                }),
      silence_(loop, [this] { checkSilence(); }),
      report_(loop, [this] { done_(std::move(failed_)); }) {
  skr_udp_init(&wire_, options.udp_key ? options.udp_key->data() : UdpKey{}.data());
}

UdpClientSession::~UdpClientSession() {
  leave();
  closeSocket();
}

void UdpClientSession::handshake(Handshaken done) {
  done_ = std::move(done);
  uint8_t nonce[8];
  size_t n = 0;
  if (::getrandom(nonce, sizeof nonce, 0) == static_cast<ssize_t>(sizeof nonce)) {
    n = skr_udp_make_hello(&wire_, user_.c_str(), nonce, tx_.data(), tx_.size());
  }
  if (n == 0) {
    failed_ =
        TransportEnd{TransportEnd::Why::error,
                     "the UDP handshake cannot start: a user name of 1 to 64 bytes is needed"};
    report_.startIn(0);
    return;
  }
  out_.assign(reinterpret_cast<const char*>(tx_.data()), n);
  step_ = Step::hello;
  watch_.watch(FdWatch::readable);
  resend();
  resend_.startEvery(kResendNs);
  deadline_.startIn(static_cast<Nanos>(handshake_ms_) * kNsPerMs);
}

void UdpClientSession::resend() {
  if (fd_ >= 0) (void)::send(fd_, out_.data(), out_.size(), MSG_DONTWAIT);
}

void UdpClientSession::handshakeOver(std::optional<TransportEnd> failed) {
  resend_.stop();
  deadline_.stop();
  if (failed) {
    step_ = Step::ended;
    watch_.stop();
  }
  if (done_) {
    Handshaken done = std::move(done_);
    done_ = nullptr;
    done(std::move(failed));  // may destroy this: last
  }
}

void UdpClientSession::onEvents(unsigned events) {
  if ((events & (FdWatch::readable | FdWatch::error)) != 0) read();
}

void UdpClientSession::read() {
  std::vector<uint8_t> buf(65536);
  for (int i = 0; i < kReadsPerWake && fd_ >= 0; ++i) {
    const ssize_t n = ::recv(fd_, buf.data(), buf.size(), 0);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) return;
    if (n < 0) {
      // An ICMP answer to an earlier datagram: nobody listens on that port.
      const std::string why = std::string("the hub's UDP port: ") + std::strerror(errno);
      if (step_ == Step::session) {
        endSession({TransportEnd::Why::error, why});
      } else if (step_ == Step::hello || step_ == Step::open) {
        handshakeOver(TransportEnd{TransportEnd::Why::refused, why});  // may destroy this
      }
      return;
    }
    datagram(buf.data(), static_cast<size_t>(n));  // may end the session or destroy this
    if (step_ != Step::session) return;
    if (!attached()) return;
  }
}

void UdpClientSession::datagram(const uint8_t* d, size_t n) {
  switch (step_) {
    case Step::hello: {
      uint8_t cookie[16];
      if (skr_udp_take_cookie(&wire_, d, n, cookie) == 0) return;
      cookie_seen_ = true;
      const size_t m = skr_udp_make_open(&wire_, user_.c_str(), cookie, tx_.data(), tx_.size());
      out_.assign(reinterpret_cast<const char*>(tx_.data()), m);
      step_ = Step::open;
      resend();
      resend_.startEvery(kResendNs);
      return;
    }
    case Step::open:
      if (skr_udp_take_accept(&wire_, d, n) == 0) return;
      step_ = Step::session;
      last_in_ = monotonicNs();
      silence_.startEvery(std::min<Nanos>(kNsPerSec, static_cast<Nanos>(silence_ms_) * kNsPerMs));
      handshakeOver(std::nullopt);  // may destroy this
      return;
    case Step::session: {
      size_t off = 0;
      size_t len = 0;
      switch (skr_udp_take(&wire_, d, n, &off, &len)) {
        case SKR_UDP_RX_DATA: {
          last_in_ = monotonicNs();
          uint32_t length = 0;
          if (len >= 4) std::memcpy(&length, d + off, 4);
          if (len < 5 || length + size_t{4} != len) return;  // not one whole frame: dropped
          if (!received(std::string_view(reinterpret_cast<const char*>(d + off), len))) {
            log::warn("udp", "UDP-OVERRUN", "a frame from the hub dropped: too many waiting");
          }
          return;
        }
        case SKR_UDP_RX_CLOSE:
          endSession({TransportEnd::Why::peer_closed, "the hub closed the UDP session"});
          return;
        default:
          return;  // dropped and counted by the wire (a replay, a bad MAC, another session)
      }
    }
    case Step::idle:
    case Step::ended:
      return;
  }
}

void UdpClientSession::checkSilence() {
  if (step_ != Step::session) return;
  if (monotonicNs() - last_in_ <= static_cast<Nanos>(silence_ms_) * kNsPerMs) return;
  endSession({TransportEnd::Why::error,
              "nothing from the hub for " + std::to_string(silence_ms_) + " ms"});
}

bool UdpClientSession::sendFrame(std::string_view frame) {
  if (step_ != Step::session || fd_ < 0) return true;  // dropped: UDP never waits
  const size_t n = skr_udp_make_data(&wire_, reinterpret_cast<const uint8_t*>(frame.data()),
                                     frame.size(), tx_.data(), max_datagram_);
  if (n == 0) {
    if (!warned_too_large_) {
      warned_too_large_ = true;
      log::warn("udp", "UDP-TOO-LARGE",
                "a frame of " + std::to_string(frame.size()) + " bytes was not sent: a datagram " +
                    "carries " + std::to_string(max_datagram_ - SKR_UDP_DATA_OVERHEAD) +
                    " at most (this session's first; others are dropped silently)");
    }
    return true;
  }
  (void)::send(fd_, tx_.data(), n, MSG_DONTWAIT);  // a full socket buffer: lost, as on the air
  return true;
}

void UdpClientSession::leaveCarrier() noexcept {
  if (step_ == Step::session && fd_ >= 0) {
    const size_t n = skr_udp_make_close(&wire_, tx_.data(), tx_.size());
    if (n > 0) (void)::send(fd_, tx_.data(), n, MSG_DONTWAIT);
  }
  step_ = Step::ended;
  closeSocket();
}

void UdpClientSession::endSession(TransportEnd end) {
  step_ = Step::ended;
  closeSocket();
  carrierEnded(std::move(end));
}

void UdpClientSession::closeSocket() noexcept {
  silence_.stop();
  resend_.stop();
  deadline_.stop();
  watch_.stop();
  watch_ = {};
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
}

}  // namespace skr::flow::transport
