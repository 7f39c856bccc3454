// SPDX-License-Identifier: Apache-2.0
// What the JSON mapping's reader and writer share: the keys of its escapes
// (docs/pair-databases.md: {"$base64": "..."} is bytes, {"$map": {...}} a map whose only key
// would otherwise read as an escape) and the scan for bytes a JSON string must escape.
#pragma once

#include <cstdint>
#include <cstring>
#include <string_view>

namespace skr::flow::json_keys {

inline constexpr std::string_view kBase64 = "$base64";
inline constexpr std::string_view kMap = "$map";

// Whether a map must be written inside {"$map": ...} to read back as a map.
template <class Map>
bool needsMapEscape(const Map& m) {
  return m.size() == 1 && (m.begin()->first == kBase64 || m.begin()->first == kMap);
}

// The length of the run at `p` that a JSON string holds as is: up to the first '"', '\\' or
// control character (below 0x20), or `end`. `ascii` is cleared when the run has a byte >= 0x80.
// Eight bytes at a time: a 64 KB string is a few microseconds.
inline size_t plainRun(const char* p, const char* end, bool& ascii) {
  constexpr uint64_t kOnes = 0x0101010101010101u;
  constexpr uint64_t kHigh = 0x8080808080808080u;
  const char* const start = p;
  uint64_t high = 0;
  while (end - p >= 8) {
    uint64_t x = 0;
    std::memcpy(&x, p, 8);
    const uint64_t quote = x ^ (kOnes * '"');
    const uint64_t slash = x ^ (kOnes * '\\');
    // Zero-byte tests (v - 0x01..) & ~v & 0x80..: exact about whether some byte matches. A byte
    // >= 0x80 keeps its high bit in x, quote and slash, so ~ masks it out of every test.
    const uint64_t special =
        (((x - kOnes * 0x20) & ~x) | ((quote - kOnes) & ~quote) | ((slash - kOnes) & ~slash)) &
        kHigh;
    if (special != 0) break;
    high |= x;
    p += 8;
  }
  for (; p != end; ++p) {
    const auto c = static_cast<unsigned char>(*p);
    if (c < 0x20 || c == '"' || c == '\\') break;
    high |= c;
  }
  if ((high & kHigh) != 0) ascii = false;
  return static_cast<size_t>(p - start);
}

}  // namespace skr::flow::json_keys
