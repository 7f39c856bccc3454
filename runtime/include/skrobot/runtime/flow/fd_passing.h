// SPDX-License-Identifier: Apache-2.0
// Passing descriptors between processes over a Unix socket (SCM_RIGHTS), for the shared-memory
// path of physical mode (docs/physical-mode.md): libuv's pipes here are not opened for passing
// descriptors, so the path's own socket carries them. On a non-blocking socket call them when it
// is ready (EAGAIN comes back as Errc::io_error).
#pragma once

#include <skrobot/runtime/result.h>

#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace skr::flow {

inline constexpr std::size_t kMaxPassedFds = 8;

// Sends `bytes` (at least one) with the descriptors attached, in one sendmsg.
[[nodiscard]] Result<void> sendWithFds(int socket, std::string_view bytes,
                                       std::span<const int> fds);

struct Received {
  std::string bytes;     // empty: the peer closed the socket
  std::vector<int> fds;  // owned by the caller (close them); CLOEXEC
};
// One recvmsg of up to `max_bytes`. More than kMaxPassedFds descriptors, or a truncated control
// message, is refused (the ones that came are closed).
[[nodiscard]] Result<Received> receiveWithFds(int socket, std::size_t max_bytes);

}  // namespace skr::flow
