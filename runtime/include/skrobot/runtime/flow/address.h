// SPDX-License-Identifier: Apache-2.0
// A hub's address, in the form ROBOT_ADDRESS and flowctl's --address take. The grammar is
// docs/flow-protocol.md's "Addresses"; transport.h opens and listens on them.
//
//   local:/tmp/Robot        a Unix socket (the default)
//   tcp:robot.local:9000    TCP; the port defaults to 9000; IPv6 as tcp:[::1]:9000
//   tls:robot.local:9000    TCP with TLS (docs/security.md); the hub's certificate must name
//                           the host as written here (a DNS name or an IP address)
//   serial:/dev/ttyUSB0@115200  a serial line (flow/serial.h), one session at a time; the rate
//                           defaults to 115200
//   udp:robot.local:9001    UDP datagrams (flow/udp.h, server.udp), one session per flow, opened
//                           with the account's key; the port defaults to 9001
//   ws:robot.local:8080/flow   WebSocket (the hub's web port, server.web): the port defaults to
//                           80 (wss: 443) as for any URL, the path to /flow; ws://... is read
//                           too; wss: is WebSocket over TLS (the hub's certificate must name the
//                           host, as for tls:). The JavaScript library reads the same forms.
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
constexpr uint16_t kDefaultWsPort = 80;    // ws: (as a ws:// URL)
constexpr uint16_t kDefaultWssPort = 443;  // wss:
constexpr std::string_view kDefaultAddress = "local:/tmp/Robot";

struct Address {
  enum class Kind { local, tcp, tls, serial, udp, ws, wss };
  Kind kind = Kind::local;
  std::string path = "/tmp/Robot";  // Kind::local; Kind::serial: the device; Kind::ws and wss:
                                    // the HTTP path ("/flow" unless given)
  std::string host{};               // Kind::tcp, tls, udp, ws, wss: a name or a numeric address
  uint16_t port = kDefaultTcpPort;  // Kind::tcp and tls; Kind::udp (kDefaultUdpPort unless
                                    // given); Kind::ws and wss (kDefaultWsPort, kDefaultWssPort)
  uint32_t baud = 115200;           // Kind::serial

  // TCP, TLS and WebSocket: where a password crosses a network (a serial line is a cable; a UDP
  // session is opened with a key, and its LOGIN's password is ignored).
  [[nodiscard]] bool isNetwork() const noexcept {
    return kind == Kind::tcp || kind == Kind::tls || kind == Kind::ws || kind == Kind::wss;
  }
  // TLS underneath: tls: and wss: (a client needs TLS settings).
  [[nodiscard]] bool usesTls() const noexcept { return kind == Kind::tls || kind == Kind::wss; }
  // "local:/tmp/Robot", "tcp:host:9000", "tls:host:9000", "serial:/dev/ttyUSB0@115200",
  // "udp:host:9001" or "ws:host:8080/flow", the form parse() reads.
  [[nodiscard]] std::string toString() const;
  // Parses "local:/path", "tcp:host[:port]", "tls:host[:port]", "serial:/dev/path[@baud]",
  // "udp:host[:port]", "ws:host[:port][/path]" or "wss:host[:port][/path]".
  // Errc::invalid_argument, naming what is wrong.
  [[nodiscard]] static Result<Address> parse(std::string_view text);
};

}  // namespace skr::flow
