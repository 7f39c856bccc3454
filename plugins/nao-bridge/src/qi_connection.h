// SPDX-License-Identifier: Apache-2.0
// One TCP connection to a qi endpoint: the socket and the messages read from it. QiClient owns
// one to the ServiceDirectory and one to each other endpoint a service lives at.
//
// Not thread-safe: owned and used by one thread. Nothing blocks without a deadline.
#pragma once

#include "qi_message.h"

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace skr::nao::qi {

// A "tcp://host:port" endpoint, as ServiceInfo lists them (IPv6 hosts in brackets).
struct Endpoint {
  std::string host;
  std::uint16_t port = 0;
  [[nodiscard]] std::string text() const;  // "host:port"
};
// Parses a "tcp://" URL; other schemes ("tcps://" needs TLS) are Errc::unsupported.
[[nodiscard]] Result<Endpoint> parseEndpoint(std::string_view url);
// 127.0.0.0/8, ::1 or "localhost": an address that means "this machine" wherever it is read.
[[nodiscard]] bool isLoopback(std::string_view host) noexcept;

class QiConnection {
 public:
  QiConnection() = default;
  ~QiConnection() { close(); }
  QiConnection(QiConnection&& o) noexcept;
  QiConnection& operator=(QiConnection&& o) noexcept;
  QiConnection(const QiConnection&) = delete;
  QiConnection& operator=(const QiConnection&) = delete;

  // A non-blocking TCP connection within timeout_ms; messages over max_payload are refused.
  [[nodiscard]] static Result<QiConnection> dial(const Endpoint& to, int timeout_ms,
                                                 std::uint32_t max_payload);

  [[nodiscard]] bool open() const noexcept { return fd_ >= 0; }
  [[nodiscard]] int fd() const noexcept { return fd_; }
  [[nodiscard]] const Endpoint& endpoint() const noexcept { return to_; }
  // Writes all of `bytes`, waiting up to 2 s for the peer to read. An error closes it.
  [[nodiscard]] Result<void> write(const std::string& bytes);
  // Reads what the socket has (call when poll says it is readable) and appends the complete
  // messages to `out`. An error (EOF, socket error, oversized or malformed message) closes it.
  [[nodiscard]] Result<void> read(std::vector<Message>& out);
  void close() noexcept;

 private:
  int fd_ = -1;
  Endpoint to_;
  std::uint32_t max_payload_ = kDefaultMaxPayload;
  MessageFramer framer_;
};

[[nodiscard]] std::int64_t monotonicNs();
// Milliseconds until deadline_ns (0 when past, at most 60 s), for poll().
[[nodiscard]] int msLeft(std::int64_t deadline_ns);

}  // namespace skr::nao::qi
