// Blocking socket helpers for the synchronous connection (internal).
#pragma once

#include <skrobot/core/result.h>
#include <skrobot/satellite/address.h>

#include <cstdint>
#include <string>
#include <string_view>

namespace skr::sat::detail {

// Connects within timeout_ms and returns a blocking, close-on-exec fd. Errc::io_error
// "no hub at <address>: is skrobot running? (<why>)" when nobody listens.
[[nodiscard]] Result<int> connectSocket(const Address& address, uint32_t timeout_ms);
// Writes every byte. Errc::closed when the peer went away.
[[nodiscard]] Result<void> sendAll(int fd, std::string_view bytes);
// Reads once (waiting up to timeout_ms) and appends to `buf`. Errc::timeout, Errc::closed.
[[nodiscard]] Result<void> readSome(int fd, std::string& buf, uint32_t timeout_ms);

}  // namespace skr::sat::detail
