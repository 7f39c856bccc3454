// SPDX-License-Identifier: Apache-2.0
// A hub's address, in the form ROBOT_ADDRESS and flowctl's --address take. The grammar, with the
// schemes reserved for later (ws:, wss:), is docs/flow-protocol.md's "Addresses"; transport.h
// opens and listens on them.
//
//   local:/tmp/Robot        a Unix socket (the default)
//   tcp:robot.local:9000    TCP; the port defaults to 9000; IPv6 as tcp:[::1]:9000
//   tls:robot.local:9000    TCP with TLS (docs/security.md); the hub's certificate must name
//                           the host as written here (a DNS name or an IP address)
//   serial:/dev/ttyUSB0@115200  a serial line (flow/serial.h), one session at a time; the rate
//                           defaults to 115200
//   udp:robot.local:9001    UDP datagrams (flow/udp.h, server.udp), one session per flow, opened
//                           with the account's key; the port defaults to 9001
//
// Parsing only: nothing here resolves a name or opens a socket.
#pragma once

#include <skrobot/runtime/result.h>

#include <cstdint>
#include <string>
#include <string_view>

namespace skr::flow {

constexpr uint16_t kDefaultTcpPort = 9000;
constexpr uint16_t kDefaultUdpPort = 9001;
constexpr std::string_view kDefaultAddress = "local:/tmp/Robot";

struct Address {
  enum class Kind { local, tcp, tls, serial, udp };
  Kind kind = Kind::local;
  std::string path = "/tmp/Robot";  // Kind::local; Kind::serial: the device
  std::string host;                 // Kind::tcp, tls and udp: a name or a numeric address
  uint16_t port = kDefaultTcpPort;  // Kind::tcp and tls; Kind::udp (kDefaultUdpPort unless given)
  uint32_t baud = 115200;           // Kind::serial

  // TCP and TLS: where a password crosses a network (a serial line is a cable; a UDP session is
  // opened with a key, and its LOGIN's password is ignored).
  [[nodiscard]] bool isNetwork() const noexcept { return kind == Kind::tcp || kind == Kind::tls; }
  // "local:/tmp/Robot", "tcp:host:9000", "tls:host:9000", "serial:/dev/ttyUSB0@115200" or
  // "udp:host:9001", the form parse() reads.
  [[nodiscard]] std::string toString() const;
  // Parses "local:/path", "tcp:host[:port]", "tls:host[:port]", "serial:/dev/path[@baud]" or
  // "udp:host[:port]".
  // Errc::invalid_argument, naming what is wrong.
  [[nodiscard]] static Result<Address> parse(std::string_view text);
};

}  // namespace skr::flow
