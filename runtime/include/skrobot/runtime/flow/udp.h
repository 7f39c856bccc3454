// SPDX-License-Identifier: Apache-2.0
// FlowProtocol over UDP for boards (an ESP32 on WiFi): server.udp's settings and what hub.stats
// shows of the port. The datagrams (a stateless cookie exchange, a per-board key, a MAC on every
// datagram, sequence numbers) are docs/flow-protocol.md's "UDP"; the board's side is
// satellite/mcu/src/skr_udp_wire.h, the hub's core/src/flow/udp_port.h, a client's (udp:
// addresses) runtime/src/transport/udp_client.h through transport::Dialer.
#pragma once

#include <skrobot/runtime/flow/transport.h>
#include <skrobot/runtime/result.h>

#include <cstdint>
#include <string>
#include <string_view>

namespace skr::flow::transport {

struct UdpOptions {
  std::string address;  // the numeric address listened on (required: no default)
  uint16_t port = 9001;
  // The largest datagram sent or received (a whole frame plus 18 bytes); below a path's MTU.
  uint32_t max_datagram = 1200;
  // A session that receives no datagram for this long ends.
  uint32_t session_timeout_ms = 10000;
};

// What went through the port, for hub.stats.
struct UdpStats {
  uint64_t datagrams_in = 0, datagrams_out = 0;
  uint64_t bytes_in = 0, bytes_out = 0;
  uint64_t cookies_sent = 0;     // COOKIEs answering HELLOs (no state kept)
  uint64_t short_hello = 0;      // HELLOs below 64 bytes: not answered
  uint64_t bad_cookie = 0;       // OPENs with a cookie this hub did not give (or too old)
  uint64_t bad_mac = 0;          // OPENs and DATA whose MAC did not hold, OPENs of keyless users
  uint64_t unknown_session = 0;  // DATA or CLOSE for no session
  uint64_t malformed = 0;        // cut short, another version or type, not a whole frame
  uint64_t replayed = 0;         // a sequence number seen already or older than the window; an OPEN
                                 // made again after its session ended
  uint64_t lost = 0;             // sequence numbers skipped and not arrived since
  uint64_t reordered = 0;        // arrived after a later one (delivered)
  uint64_t too_large = 0;        // frames not sent: above max_datagram
  uint64_t send_failed = 0;      // datagrams the system refused (a full socket buffer)
  uint64_t overrun = 0;          // frames dropped: a paused session had too many waiting
  uint64_t sessions = 0;         // sessions opened
  uint64_t timeouts = 0;         // sessions ended by session_timeout_ms
};

// An account's key as `skrobot user key NAME` prints it: 32 hex digits (white space around them
// is ignored). Errc::invalid_argument otherwise; the message never repeats the text.
[[nodiscard]] Result<UdpKey> parseUdpKey(std::string_view hex);
// The key in a file that holds its hex (ROBOT_UDP_KEY_FILE, flowctl --udp-key-file): the file's
// errors name it (Errc::not_found, Errc::io_error), and a bad key is Errc::invalid_argument.
[[nodiscard]] Result<UdpKey> readUdpKeyFile(const std::string& path);

}  // namespace skr::flow::transport
