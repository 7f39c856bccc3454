// SPDX-License-Identifier: Apache-2.0
// Blocking socket helpers for the synchronous connection (internal).
#pragma once

#include <skrobot/runtime/flow/tls.h>
#include <skrobot/runtime/result.h>
#include <skrobot/satellite/address.h>

#include <cstdint>
#include <string>
#include <string_view>

namespace skr::sat::detail {

// Connects within timeout_ms and returns a blocking, close-on-exec fd. Errc::io_error
// "no hub at <address>: is skrobot running? (<why>)" when nobody listens.
[[nodiscard]] Result<int> connectSocket(const Address& address, uint32_t timeout_ms);
// The TLS handshake on a connected socket, within timeout_ms. Errc::io_error naming the address
// and the reason (certificate verify failed: ..., the hub closed the connection, ...).
[[nodiscard]] Result<flow::TlsSession> tlsHandshake(int fd, const flow::TlsContext& context,
                                                    const Address& address, uint32_t timeout_ms);
// Writes every byte of `bytes` and then of `more` (encrypted first with `tls`). Errc::closed when
// the peer went away.
[[nodiscard]] Result<void> sendAll(int fd, flow::TlsSession* tls, std::string_view bytes,
                                   std::string_view more = {});
// Reads what has arrived, up to `room` bytes, into `dst` (decrypted with `tls`), waiting up to
// timeout_ms for at least one byte; returns the count. Errc::timeout, Errc::closed.
[[nodiscard]] Result<size_t> readSome(int fd, flow::TlsSession* tls, char* dst, size_t room,
                                      uint32_t timeout_ms);
// Sends close_notify, best effort.
void closeTls(int fd, flow::TlsSession& tls) noexcept;

}  // namespace skr::sat::detail
