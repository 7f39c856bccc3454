// SPDX-License-Identifier: Apache-2.0
// server.udp: the hub's UDP port for boards (docs/flow-protocol.md, "UDP"). A Listener over one
// datagram socket: HELLOs are answered with a stateless cookie (never more bytes than the HELLO),
// an OPEN with a valid cookie and a MAC by the user's key makes a session, handed to the server as
// a Transport with one whole frame per datagram (Framing::messages), already bound to that
// account. DATA and CLOSE carry a MAC by the session key and a sequence number (replays dropped,
// loss and reordering counted). A session with no datagram for session_timeout_ms ends.
//
// Thread: the loop's, as every transport (transport.h). The key lookup (KeyOf) runs on it: it
// must not block (the Authenticator answers from the users file it holds in memory).
#pragma once

#include "udp_wire.h"

#include <skrobot/runtime/flow/transport.h>
#include <skrobot/runtime/flow/udp.h>

#include <functional>
#include <memory>
#include <optional>
#include <string_view>

namespace skr::flow {

class UdpPort : public transport::Listener {
 public:
  // The key of `user`; nullopt when the user has none (or does not exist).
  using KeyOf = std::function<std::optional<udp::Key>(std::string_view user)>;

  // Binds options.address (numeric) : options.port (0: a free one). Errc::invalid_argument for a
  // name or a max_datagram below 128; Errc::io_error with the system's reason.
  [[nodiscard]] static Result<std::unique_ptr<UdpPort>> open(Loop& loop,
                                                             transport::UdpOptions options,
                                                             KeyOf key_of, Accepted accepted);
  [[nodiscard]] virtual const transport::UdpStats& stats() const noexcept = 0;
  [[nodiscard]] virtual size_t sessions() const noexcept = 0;
};

}  // namespace skr::flow
