// SPDX-License-Identifier: Apache-2.0
// qi messages: a 28-byte header then the payload (qiloop notes, "Message Header").
//   magic u32 (0x42dead42, big-endian) | id u32 | size u32 | version u16 | type u8 | flags u8 |
//   service u32 | object u32 | action u32       (all but the magic little-endian)
#pragma once

#include <skrobot/result.hpp>

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace skr::nao::qi {

constexpr std::uint32_t kMagic = 0x42dead42;
constexpr std::size_t kHeaderSize = 28;
constexpr std::uint32_t kDefaultMaxPayload = 16u << 20;

enum class MsgType : std::uint8_t {
  unknown = 0,
  call = 1,
  reply = 2,
  error = 3,
  post = 4,
  event = 5,
  capability = 6,
  cancel = 7,
  cancelled = 8,
};

// Flags (with the MessageFlags capability): the payload is a dynamic value ('m').
constexpr std::uint8_t kFlagDynamicPayload = 0x1;
constexpr std::uint8_t kFlagReturnType = 0x2;

// Well-known addresses.
constexpr std::uint32_t kServiceServer = 0;  // object 0: authentication
constexpr std::uint32_t kActionAuthenticate = 8;
constexpr std::uint32_t kServiceDirectory = 1;  // object 1
constexpr std::uint32_t kMainObject = 1;        // every service's main object
constexpr std::uint32_t kActionMetaObject = 2;  // metaObject(I) on any object
constexpr std::uint32_t kActionService = 100;   // ServiceDirectory.service(s)

struct Header {
  std::uint32_t id = 0;
  std::uint32_t size = 0;
  std::uint16_t version = 0;
  MsgType type = MsgType::unknown;
  std::uint8_t flags = 0;
  std::uint32_t service = 0;
  std::uint32_t object = 0;
  std::uint32_t action = 0;
};

struct Message {
  Header header;
  std::string payload;
};

// Header and payload as bytes; header.size is taken from the payload.
[[nodiscard]] std::string encodeMessage(Header header, std::string_view payload);
// Checks magic, version 0, a known type and size <= max_payload. `bytes` holds >= 28 bytes.
[[nodiscard]] Result<Header> parseHeader(std::string_view bytes, std::uint32_t max_payload);

// Cuts a byte stream into messages. A header that fails parseHeader is an error: the stream
// cannot be resynchronised, so the caller closes the connection. Nothing is allocated for a
// payload before its size was checked.
class MessageFramer {
 public:
  explicit MessageFramer(std::uint32_t max_payload = kDefaultMaxPayload)
      : max_payload_(max_payload) {}
  void append(std::string_view bytes) { buf_.append(bytes); }
  // The next complete message, nullopt when more bytes are needed, or an error.
  [[nodiscard]] Result<std::optional<Message>> next();
  [[nodiscard]] std::size_t buffered() const noexcept { return buf_.size(); }

 private:
  std::uint32_t max_payload_;
  std::string buf_;
};

}  // namespace skr::nao::qi
