// SPDX-License-Identifier: Apache-2.0
// FlowProtocol: frame layout, command codes, error codes and limits. docs/flow-protocol.md is the
// byte-by-byte specification; this header is its code. Used by the hub, the satellite libraries,
// the tests and the fuzz targets.
//
// A frame: u32 length (bytes after this field, >= 1), u8 code, body. Little-endian throughout.
#pragma once

#include <skrobot/runtime/flow/catalogue.h>
#include <skrobot/result.hpp>

#include <cstdint>
#include <span>
#include <string>
#include <string_view>

namespace skr::flow {

constexpr uint16_t kProtocolMajor = 1;
constexpr uint16_t kProtocolMinor = 13;  // history: docs/flow-protocol.md, "Minor versions"

constexpr size_t kFrameHeaderBytes = 5;                       // u32 length + u8 code
constexpr uint32_t kDefaultMaxFrameBytes = 16 * 1024 * 1024;  // the length field's limit
constexpr uint32_t kMaxChannels = 32768;
// The largest frame a hub reads before LOGIN succeeded: a LOGIN with the longest user name and
// password and a long client name fits.
constexpr uint32_t kPreLoginMaxFrameBytes = 4096;

// Every code of the protocol, from the catalogue (catalogue.h): Code::login = 0x01, ...
enum class Code : uint8_t {
#define SKR_FLOW_CODE_ENUM(code, name, ...) name = code,
  SKR_FLOW_CATALOGUE(SKR_FLOW_CODE_ENUM)
#undef SKR_FLOW_CODE_ENUM
};

// Who sends a code, on which connection, and which part of the hub handles it (catalogue.h).
enum class Direction : uint8_t { to_hub, to_client };
enum class Via : uint8_t { sync, flow, link_sync, link_flow };
enum class Family : uint8_t {
  session,
  channels,
  databases,
  services,
  blobs,
  sync,
  links,
  physical,
  admin
};
[[nodiscard]] std::string_view familyName(Family family) noexcept;
[[nodiscard]] std::string_view viaName(Via via) noexcept;

// A code's row of the catalogue. `name` is the wire name (LOGIN).
struct CodeInfo {
  uint8_t code = 0;
  std::string_view name;
  uint16_t minor = 0;
  Direction direction = Direction::to_hub;
  Via via = Via::sync;
  Family family = Family::session;
  // On a synchronous connection (sync, link_sync): one reply per request, in order.
  [[nodiscard]] constexpr bool synchronous() const noexcept {
    return via == Via::sync || via == Via::link_sync;
  }
  // Sent between hubs only (link_sync, link_flow).
  [[nodiscard]] constexpr bool hubsOnly() const noexcept {
    return via == Via::link_sync || via == Via::link_flow;
  }
};
// The row of `code`, or null for a code no minor assigned (yet).
[[nodiscard]] const CodeInfo* codeInfo(uint8_t code) noexcept;
// Every row, in code order.
[[nodiscard]] std::span<const CodeInfo> catalogue() noexcept;

// The wire name of a code ("LOGIN"); "UNKNOWN" for a code the catalogue does not have.
[[nodiscard]] std::string_view codeName(uint8_t code) noexcept;

enum class ErrorCode : uint16_t {
#define SKR_FLOW_ERROR_ENUM(value, name, minor) name = value,
  SKR_FLOW_ERRORS(SKR_FLOW_ERROR_ENUM)
#undef SKR_FLOW_ERROR_ENUM
};

[[nodiscard]] std::string_view errorCodeName(ErrorCode code) noexcept;

// The protocol minor that introduced `code` (0 for everything of 1.0). A request newer than the
// connection's minor (the lower of the client's and the hub's) is answered `unsupported`.
[[nodiscard]] uint16_t minorOf(Code code) noexcept;

// The one mapping between wire errors and skr::Errc, used by the hub, its modules (LocalClient)
// and the satellite libraries, so that a failure reaches every client as the same code.
// Every ErrorCode has the Errc of the same name, and toErrorCode(toErrc(e)) == e. Codes that never
// travel map onto the nearest wire error: config_error and parse_error -> invalid_argument,
// closed -> io_error, abi_mismatch, module_failed, exception and remote -> internal.
[[nodiscard]] Errc toErrc(ErrorCode code) noexcept;
[[nodiscard]] ErrorCode toErrorCode(Errc code) noexcept;
// A wire error as an Error (toErrc(code) and the peer's message).
[[nodiscard]] Error wireError(ErrorCode code, std::string message);

// sync (1.4): a sync pulse source; it carries pulses, not data.
enum class ChannelKind : uint8_t {
#define SKR_FLOW_KIND_ENUM(value, name, minor) name = value,
  SKR_FLOW_CHANNEL_KINDS(SKR_FLOW_KIND_ENUM)
#undef SKR_FLOW_KIND_ENUM
};
[[nodiscard]] std::string_view channelKindName(ChannelKind kind) noexcept;
// The protocol minor that introduced a channel kind (0 for those of 1.0).
[[nodiscard]] uint16_t minorOfKind(ChannelKind kind) noexcept;

// How a frame carries a typed value: u8 encoding, then a binary Variant or u32 length + JSON text.
enum class ValueEncoding : uint8_t { binary = 0, json = 1 };

// Splits a byte stream into frames. Feed it what the socket gave; it never allocates more than
// the announced length of a frame, and only after checking that length against the limit.
class FrameSplitter {
 public:
  explicit FrameSplitter(uint32_t max_frame_bytes = kDefaultMaxFrameBytes)
      : max_(max_frame_bytes) {}

  enum class Status { frame, need_more, too_large, empty_frame };

  // Looks at the buffered bytes [data, data+size) and reports the next frame: on `frame`,
  // `code`, `body` (a view into data) and `consumed` (header + body) are set. On `need_more`,
  // `wanted` is the total number of bytes the next frame needs (header included) when known.
  struct Next {
    Status status = Status::need_more;
    uint8_t code = 0;
    std::string_view body;
    size_t consumed = 0;
    size_t wanted = 0;
    uint32_t announced = 0;  // the length field, for error messages
  };
  [[nodiscard]] Next next(const uint8_t* data, size_t size) const noexcept;
  [[nodiscard]] uint32_t maxFrameBytes() const noexcept { return max_; }
  void setMaxFrameBytes(uint32_t max_frame_bytes) noexcept { max_ = max_frame_bytes; }

 private:
  uint32_t max_;
};

// Appends a frame header for a body of `body_bytes` bytes; the caller appends the body.
void appendHeader(std::string& out, Code code, size_t body_bytes);

}  // namespace skr::flow
