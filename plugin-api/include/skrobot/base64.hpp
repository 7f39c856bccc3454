// SPDX-License-Identifier: Apache-2.0
// Standard base64 (RFC 4648, with padding): the project's one implementation, used by the JSON
// mapping of bytes values ({"$base64": ...}), the module-support library and Foxglove's image
// messages. Header-only, so that each module carries its own copy.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace skr::base64 {
namespace detail {

inline constexpr char kAlphabet[] =
    "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";

// Each byte's value as a base64 digit; 64: not one.
inline constexpr auto kValues = [] {
  std::array<std::uint8_t, 256> t{};
  t.fill(64);
  for (std::size_t i = 0; i < 64; ++i) {
    t[static_cast<unsigned char>(kAlphabet[i])] = static_cast<std::uint8_t>(i);
  }
  return t;
}();

}  // namespace detail

// Appends the base64 of `bytes` to `out`.
inline void append(std::string& out, std::string_view bytes) {
  using detail::kAlphabet;
  const std::size_t at = out.size();
  out.resize(at + (bytes.size() + 2) / 3 * 4);
  char* o = out.data() + at;
  const auto* in = reinterpret_cast<const unsigned char*>(bytes.data());
  std::size_t i = 0;
  for (; i + 3 <= bytes.size(); i += 3) {
    const std::uint32_t v = std::uint32_t{in[i]} << 16 | std::uint32_t{in[i + 1]} << 8 | in[i + 2];
    *o++ = kAlphabet[v >> 18 & 63];
    *o++ = kAlphabet[v >> 12 & 63];
    *o++ = kAlphabet[v >> 6 & 63];
    *o++ = kAlphabet[v & 63];
  }
  if (const std::size_t rest = bytes.size() - i; rest > 0) {
    std::uint32_t v = std::uint32_t{in[i]} << 16;
    if (rest == 2) v |= std::uint32_t{in[i + 1]} << 8;
    *o++ = kAlphabet[v >> 18 & 63];
    *o++ = kAlphabet[v >> 12 & 63];
    *o++ = rest == 2 ? kAlphabet[v >> 6 & 63] : '=';
    *o++ = '=';
  }
}

[[nodiscard]] inline std::string encode(std::string_view bytes) {
  std::string out;
  append(out, bytes);
  return out;
}

// The bytes of standard base64 text; nullopt for anything else: another alphabet (URL-safe),
// missing or misplaced padding, a length that is not a multiple of 4, non-zero unused bits.
[[nodiscard]] inline std::optional<std::string> decode(std::string_view text) {
  using detail::kValues;
  if (text.size() % 4 != 0) return std::nullopt;
  std::size_t pad = 0;
  if (!text.empty() && text.back() == '=') pad = text[text.size() - 2] == '=' ? 2 : 1;
  std::string out(text.size() / 4 * 3 - pad, '\0');
  const auto* in = reinterpret_cast<const unsigned char*>(text.data());
  char* o = out.data();
  const std::size_t whole = text.size() - (pad != 0 ? 4 : 0);  // groups without padding
  std::uint8_t bad = 0;
  for (std::size_t i = 0; i < whole; i += 4) {
    const std::uint8_t a = kValues[in[i]], b = kValues[in[i + 1]];
    const std::uint8_t c = kValues[in[i + 2]], d = kValues[in[i + 3]];
    bad |= (a | b | c | d) & 64;
    const std::uint32_t v = std::uint32_t{a} << 18 | std::uint32_t{b} << 12 | c << 6 | d;
    *o++ = static_cast<char>(v >> 16);
    *o++ = static_cast<char>(v >> 8 & 0xff);
    *o++ = static_cast<char>(v & 0xff);
  }
  if (pad != 0) {  // the last group: 2 or 3 digits, then '='
    const std::uint8_t a = kValues[in[whole]], b = kValues[in[whole + 1]];
    const std::uint8_t c = pad == 1 ? kValues[in[whole + 2]] : 0;
    bad |= (a | b | c) & 64;
    const std::uint32_t v = std::uint32_t{a} << 18 | std::uint32_t{b} << 12 | (c & 63) << 6;
    bad |= (v & (pad == 1 ? 0xff : 0xffff)) != 0 ? 64 : 0;  // unused bits must be zero
    *o++ = static_cast<char>(v >> 16);
    if (pad == 1) *o++ = static_cast<char>(v >> 8 & 0xff);
  }
  if (bad != 0) return std::nullopt;
  return out;
}

}  // namespace skr::base64
