// SPDX-License-Identifier: Apache-2.0
// The hub's reader and writer of a board's UDP datagrams (docs/flow-protocol.md, "UDP"; the
// board's side is satellite/mcu/src/skr_udp_wire.h): every length checked before use, MACs with
// libsodium (SipHash-2-4: crypto_shorthash_siphashx24 for the handshake, crypto_shorthash_siphash24
// for DATA and CLOSE), the replay window. Pure functions, no sockets: the fuzz target
// (tests/fuzz/udp_datagram_fuzz.cpp) runs them as the hub does.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace skr::flow::udp {

using Key = std::array<uint8_t, 16>;
using Nonce = std::array<uint8_t, 8>;
using Mac64 = std::array<uint8_t, 8>;

constexpr uint8_t kVersion = 1;
enum class Type : uint8_t { hello = 1, cookie = 2, open = 3, accept = 4, data = 5, close = 6 };
constexpr size_t kHelloBytes = 64;    // a HELLO below this is not answered (no amplification)
constexpr size_t kCookieBytes = 26;   // type, version, client nonce, cookie
constexpr size_t kAcceptBytes = 38;   // type, version, client nonce, session, server nonce, mac
constexpr size_t kDataOverhead = 18;  // type, version, session, seq, mac
constexpr size_t kMaxUser = 64;

struct Hello {
  std::string_view user;
  Nonce nonce{};
};
struct Open {
  std::string_view user;
  Nonce nonce{};
  Key cookie{};
  Key mac{};
  std::string_view signed_part;  // everything before the MAC
};
// DATA or CLOSE.
struct Numbered {
  Type type = Type::data;
  uint32_t session = 0;
  uint32_t seq = 0;
  std::string_view frame;        // DATA: one frame (not checked here); CLOSE: empty
  std::string_view signed_part;  // everything before the MAC
  Mac64 mac{};
};

// The datagram's type when its version is ours and it holds at least the type and version.
[[nodiscard]] std::optional<Type> typeOf(std::string_view d) noexcept;
// Each: the datagram's fields when it is one of that type, whole, with a valid user name length.
[[nodiscard]] std::optional<Hello> parseHello(std::string_view d) noexcept;  // >= 64 bytes only
[[nodiscard]] std::optional<Open> parseOpen(std::string_view d) noexcept;
[[nodiscard]] std::optional<Numbered> parseNumbered(std::string_view d) noexcept;
// Whether `frame` is one whole FlowProtocol frame (u32 length | code | body, length = code+body).
[[nodiscard]] bool wholeFrame(std::string_view frame) noexcept;

// SipHash-2-4: 128-bit and 64-bit outputs.
[[nodiscard]] Key mac128(const Key& key, std::string_view bytes) noexcept;
[[nodiscard]] Mac64 mac64(const Key& key, std::string_view bytes) noexcept;
// Constant-time comparison.
[[nodiscard]] bool sameMac(const uint8_t* a, const uint8_t* b, size_t n) noexcept;

// The cookie a HELLO from `peer` (its address bytes and port, as the hub writes them) gets in
// `minute`: SipHash-128(secret, peer | str8 user | nonce | u64 minute).
[[nodiscard]] Key cookie(const Key& secret, std::string_view peer, std::string_view user,
                         const Nonce& nonce, uint64_t minute) noexcept;
[[nodiscard]] Key sessionKey(const Key& key, const Nonce& client, const Nonce& server) noexcept;

[[nodiscard]] std::string makeCookie(const Nonce& nonce, const Key& cookie);
[[nodiscard]] std::string makeAccept(const Key& key, const Nonce& client, uint32_t session,
                                     const Nonce& server);
// DATA with `frame` (CLOSE with none), MACed with the session key.
[[nodiscard]] std::string makeNumbered(Type type, const Key& session_key, uint32_t session,
                                       uint32_t seq, std::string_view frame);

// The receiver's sequence numbers: the highest seen and a 64-datagram window below it.
struct ReplayWindow {
  enum class Verdict : uint8_t { fresh, late, replayed };
  uint32_t highest = 0;
  uint64_t bits = 0;  // bit i: highest - i was received
  // `lost` grows by the numbers a fresh one skipped and shrinks when a late one fills a gap.
  Verdict take(uint32_t seq, uint64_t& lost) noexcept;
};

}  // namespace skr::flow::udp
