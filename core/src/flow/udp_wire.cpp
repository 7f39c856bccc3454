// SPDX-License-Identifier: Apache-2.0
#include "udp_wire.h"

#include <sodium.h>

#include <cstring>

namespace skr::flow::udp {
namespace {

constexpr std::string_view kSessionLabel = "skr-udp-session";

uint32_t get32(std::string_view d, size_t at) noexcept {
  const auto* p = reinterpret_cast<const uint8_t*>(d.data() + at);
  return uint32_t{p[0]} | uint32_t{p[1]} << 8 | uint32_t{p[2]} << 16 | uint32_t{p[3]} << 24;
}

void put32(std::string& out, uint32_t v) {
  for (int i = 0; i < 4; ++i) out.push_back(static_cast<char>((v >> (8 * i)) & 0xFF));
}

template <size_t N>
std::array<uint8_t, N> bytesAt(std::string_view d, size_t at) noexcept {
  std::array<uint8_t, N> a{};
  std::memcpy(a.data(), d.data() + at, N);
  return a;
}

template <size_t N>
void append(std::string& out, const std::array<uint8_t, N>& a) {
  out.append(reinterpret_cast<const char*>(a.data()), N);
}

// str8 user at offset 2: its view when it fits in `d` with `after` more bytes behind it.
std::optional<std::string_view> userAt(std::string_view d, size_t after) noexcept {
  if (d.size() < 3) return std::nullopt;
  const size_t n = static_cast<uint8_t>(d[2]);
  if (n > kMaxUser || d.size() < 3 + n + after) return std::nullopt;
  return d.substr(3, n);
}

}  // namespace

std::optional<Type> typeOf(std::string_view d) noexcept {
  if (d.size() < 2 || static_cast<uint8_t>(d[1]) != kVersion) return std::nullopt;
  const auto t = static_cast<uint8_t>(d[0]);
  if (t < 1 || t > 6) return std::nullopt;
  return static_cast<Type>(t);
}

std::optional<Hello> parseHello(std::string_view d) noexcept {
  if (d.size() < kHelloBytes || typeOf(d) != Type::hello) return std::nullopt;
  auto user = userAt(d, 8);
  if (!user) return std::nullopt;
  return Hello{*user, bytesAt<8>(d, 3 + user->size())};
}

std::optional<Open> parseOpen(std::string_view d) noexcept {
  if (typeOf(d) != Type::open) return std::nullopt;
  auto user = userAt(d, 8 + 16 + 16);
  if (!user || d.size() != 3 + user->size() + 40) return std::nullopt;
  const size_t at = 3 + user->size();
  return Open{*user, bytesAt<8>(d, at), bytesAt<16>(d, at + 8), bytesAt<16>(d, at + 24),
              d.substr(0, at + 24)};
}

std::optional<Numbered> parseNumbered(std::string_view d) noexcept {
  const auto t = typeOf(d);
  if (!t || (*t != Type::data && *t != Type::close) || d.size() < kDataOverhead) {
    return std::nullopt;
  }
  if (*t == Type::close && d.size() != kDataOverhead) return std::nullopt;
  const size_t body = d.size() - 8;
  return Numbered{*t,
                  get32(d, 2),
                  get32(d, 6),
                  d.substr(10, body - 10),
                  d.substr(0, body),
                  bytesAt<8>(d, body)};
}

bool wholeFrame(std::string_view frame) noexcept {
  return frame.size() >= 5 && get32(frame, 0) == frame.size() - 4;
}

Key mac128(const Key& key, std::string_view bytes) noexcept {
  Key out{};
  crypto_shorthash_siphashx24(out.data(), reinterpret_cast<const unsigned char*>(bytes.data()),
                              bytes.size(), key.data());
  return out;
}

Mac64 mac64(const Key& key, std::string_view bytes) noexcept {
  Mac64 out{};
  crypto_shorthash_siphash24(out.data(), reinterpret_cast<const unsigned char*>(bytes.data()),
                             bytes.size(), key.data());
  return out;
}

bool sameMac(const uint8_t* a, const uint8_t* b, size_t n) noexcept {
  return sodium_memcmp(a, b, n) == 0;
}

Key cookie(const Key& secret, std::string_view peer, std::string_view user, const Nonce& nonce,
           uint64_t minute) noexcept {
  std::string m;
  m.reserve(peer.size() + user.size() + 17);
  m.append(peer);
  m.push_back(static_cast<char>(user.size()));
  m.append(user);
  append(m, nonce);
  for (int i = 0; i < 8; ++i) m.push_back(static_cast<char>((minute >> (8 * i)) & 0xFF));
  return mac128(secret, m);
}

Key sessionKey(const Key& key, const Nonce& client, const Nonce& server) noexcept {
  std::string m(kSessionLabel);
  append(m, client);
  append(m, server);
  return mac128(key, m);
}

std::string makeCookie(const Nonce& nonce, const Key& cookie) {
  std::string out{static_cast<char>(Type::cookie), static_cast<char>(kVersion)};
  append(out, nonce);
  append(out, cookie);
  return out;
}

std::string makeAccept(const Key& key, const Nonce& client, uint32_t session, const Nonce& server) {
  std::string out{static_cast<char>(Type::accept), static_cast<char>(kVersion)};
  append(out, client);
  put32(out, session);
  append(out, server);
  append(out, mac128(key, out));
  return out;
}

std::string makeNumbered(Type type, const Key& session_key, uint32_t session, uint32_t seq,
                         std::string_view frame) {
  std::string out{static_cast<char>(type), static_cast<char>(kVersion)};
  out.reserve(kDataOverhead + frame.size());
  put32(out, session);
  put32(out, seq);
  out.append(frame);
  append(out, mac64(session_key, out));
  return out;
}

// The same rule as skr_udp_window() on the board (satellite/mcu/src/skr_udp_wire.c).
ReplayWindow::Verdict ReplayWindow::take(uint32_t seq, uint64_t& lost) noexcept {
  if (seq > highest) {
    const uint32_t d = seq - highest;
    lost += d - 1;
    bits = d >= 64 ? 0 : bits << d;
    bits |= 1;
    highest = seq;
    return Verdict::fresh;
  }
  const uint32_t d = highest - seq;
  if (seq == 0 || d >= 64 || ((bits >> d) & 1u) != 0) return Verdict::replayed;
  bits |= uint64_t{1} << d;
  if (lost > 0) --lost;
  return Verdict::late;
}

}  // namespace skr::flow::udp
