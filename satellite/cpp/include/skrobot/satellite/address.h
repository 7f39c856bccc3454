// SPDX-License-Identifier: Apache-2.0
// Where the hub is and who we are: ROBOT_ADDRESS, ROBOT_USER, ROBOT_PASSWORD, and for tls:
// addresses ROBOT_TLS_CA, ROBOT_TLS_CERT, ROBOT_TLS_KEY (docs/security.md).
// The address forms are skr::flow::Address's (skrobot/runtime/flow/address.h, in the runtime
// library).
#pragma once

#include <skrobot/runtime/flow/address.h>
#include <skrobot/runtime/flow/protocol.h>
#include <skrobot/runtime/flow/tls.h>
#include <skrobot/runtime/result.h>

#include <cstdint>
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

  // Reads ROBOT_ADDRESS, ROBOT_USER, ROBOT_PASSWORD, ROBOT_TLS_CA, ROBOT_TLS_CERT and
  // ROBOT_TLS_KEY; unset (or empty) variables keep the defaults above.
  // Errc::invalid_argument when ROBOT_ADDRESS cannot be parsed.
  [[nodiscard]] static Result<ConnectOptions> fromEnvironment(std::string client_name = {});
};

}  // namespace skr::sat
