// SPDX-License-Identifier: Apache-2.0
// Where the hub is and who we are: ROBOT_ADDRESS, ROBOT_USER, ROBOT_PASSWORD, for tls:
// addresses ROBOT_TLS_CA, ROBOT_TLS_CERT, ROBOT_TLS_KEY (docs/security.md), and for udp:
// addresses the account's key, ROBOT_UDP_KEY or ROBOT_UDP_KEY_FILE (docs/flow-protocol.md).
// The address forms are skr::flow::Address's (skrobot/runtime/flow/address.h, in the runtime
// library).
#pragma once

#include <skrobot/runtime/flow/address.h>
#include <skrobot/runtime/flow/protocol.h>
#include <skrobot/runtime/flow/tls.h>
#include <skrobot/runtime/flow/transport.h>
#include <skrobot/runtime/result.h>

#include <cstdint>
#include <optional>
#include <string>

namespace skr::sat {

using flow::Address;
using flow::kDefaultAddress;
using flow::kDefaultTcpPort;

// How to reach and log in to a hub. Plain data; copy it freely.
struct ConnectOptions {
  Address address;
  std::string user = "guest";
  std::string password = "password";
  std::string client_name;  // shown in the hub's log lines; may be empty
  uint32_t max_frame_bytes = flow::kDefaultMaxFrameBytes;  // a bigger incoming frame is an error
  uint32_t timeout_ms = 5000;  // connect and each synchronous reply (SERVICE_CALL adds its own)
  // For tls: addresses. ca_file: the CA that signed the hub's certificate (empty: the system's
  // CA store); cert_file and key_file: our certificate, for a hub that asks for one. The hub's
  // certificate must name the address's host. Read when the first connection is made.
  flow::TlsSettings tls;
  // For udp: addresses: the 16-byte key of `user`'s account (`skrobot user key NAME` prints its
  // hex; flow::transport::parseUdpKey reads it). The session is opened with it; the password is
  // not sent to the hub's check (a UDP session's LOGIN needs none). timeout_ms bounds the
  // handshake: a wrong key is an error once it has passed.
  std::optional<flow::transport::UdpKey> udp_key;

  // Reads ROBOT_ADDRESS, ROBOT_USER, ROBOT_PASSWORD, ROBOT_TLS_CA, ROBOT_TLS_CERT,
  // ROBOT_TLS_KEY, and ROBOT_UDP_KEY (the key's hex) or else ROBOT_UDP_KEY_FILE (a file holding
  // it); unset (or empty) variables keep the defaults above. Errc::invalid_argument when
  // ROBOT_ADDRESS or ROBOT_UDP_KEY cannot be parsed; the key file's errors name it.
  [[nodiscard]] static Result<ConnectOptions> fromEnvironment(std::string client_name = {});
};

}  // namespace skr::sat
