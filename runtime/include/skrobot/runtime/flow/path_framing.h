// SPDX-License-Identifier: Apache-2.0
// The reduced framing of physical mode's path sockets (docs/physical-mode.md): what an owner and a
// subscriber say on the owner's socket once the hub granted the path. Pure functions, fuzzed by
// path_frame_fuzz. Every frame is u32 length (of what follows, type included), u8 type, body.
//   HELLO   (subscriber -> owner) u8 version 1, u8 path, str16 channel, str16 token
//   WELCOME (owner -> subscriber) u16 error (0 ok), str16 message; for shared memory three
//           descriptors come with it (the ring read-only, the lease page, the eventfd)
//   DATA    (owner -> subscriber, direct) u64 seq, i64 capture_ns, the payload
//   BYE     (either) str16 reason
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace skr::flow::path {

enum class Type : uint8_t { hello = 1, welcome = 2, data = 3, bye = 4 };
inline constexpr uint32_t kMaxControlBytes = 4096;    // HELLO, WELCOME, BYE
inline constexpr uint32_t kMaxDataBytes = 64u << 20;  // DATA
inline constexpr size_t kDataHeadBytes = 4 + 1 + 16;  // what comes before a DATA payload

struct Hello {
  uint8_t version = 1;
  uint8_t path = 0;
  std::string channel, token;
};
struct Welcome {
  uint16_t error = 0;
  std::string message;
};
struct Data {
  uint64_t seq = 0;
  int64_t capture_ns = 0;
  std::string_view payload;
};

[[nodiscard]] std::string encode(const Hello& m);
[[nodiscard]] std::string encode(const Welcome& m);
[[nodiscard]] std::string encodeBye(std::string_view reason);
// The header of a DATA frame with a payload of `payload_bytes`: write it, then the payload.
[[nodiscard]] std::string dataHead(uint64_t seq, int64_t capture_ns, size_t payload_bytes);

// The next frame at the front of `in`. too_large: its length is 0 or over `max` (refused before
// anything is read or allocated for it).
struct Next {
  enum class Status { frame, need_more, too_large } status = Status::need_more;
  uint8_t type = 0;
  std::string_view body;
  size_t size = 0;         // the whole frame
  uint32_t announced = 0;  // the length field
};
[[nodiscard]] Next next(std::string_view in, uint32_t max);

// A body of the given type, or nullopt when it is malformed (short, trailing bytes, a version
// that is not 1).
[[nodiscard]] std::optional<Hello> decodeHello(std::string_view body);
[[nodiscard]] std::optional<Welcome> decodeWelcome(std::string_view body);
[[nodiscard]] std::optional<Data> decodeData(std::string_view body);
[[nodiscard]] std::optional<std::string> decodeBye(std::string_view body);

}  // namespace skr::flow::path
