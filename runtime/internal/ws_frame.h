// SPDX-License-Identifier: Apache-2.0
// RFC 6455 framing for FlowProtocol over WebSocket (runtime/src/transport/ws_transport.h): the
// frame header writer and the frame reader, pure (no loop, no socket: the fuzz target
// tests/fuzz/ws_frame_fuzz.cpp runs the reader on arbitrary bytes). Internal to the runtime.
//
// For FlowProtocol the reader takes binary messages only and unmasks their payload straight into
// the sink's buffer: no message is buffered, so the FlowProtocol frame limit (the receiver's check
// of each 4-byte length before it allocates) stays the only limit. It also walks those length
// prefixes, so that a message that ends inside a FlowProtocol frame is refused (close 1007): every
// WebSocket message holds whole frames.
//
// For other subprotocols (a module's, plugin ABI 1.8) it reads messages: text and binary, each at
// most a given size, refused (close 1009) on the frame header that would take it over, before any
// of its payload is read; the sink hears where each one ends (messageEnd).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>

namespace skr::flow::ws {

enum class Opcode : uint8_t {
  continuation = 0,
  text = 1,
  binary = 2,
  close = 8,
  ping = 9,
  pong = 10
};

// The close codes this layer sends (RFC 6455 7.4.1).
enum CloseCode : uint16_t {
  kCloseNormal = 1000,
  kCloseGoingAway = 1001,
  kCloseProtocolError = 1002,
  kCloseUnsupportedData = 1003,
  kCloseInvalidPayload = 1007,
  kCloseMessageTooBig = 1009,
};

constexpr size_t kMaxHeaderBytes = 14;
constexpr size_t kMaxControlPayload = 125;
using MaskKey = std::array<uint8_t, 4>;

// Writes the header of a frame of `length` payload bytes into `out` (room for kMaxHeaderBytes)
// and returns its size: 2 to 10 bytes, 4 more with a mask.
size_t writeHeader(char* out, Opcode op, bool fin, uint64_t length,
                   const MaskKey* mask = nullptr) noexcept;
// XORs `n` bytes with the mask, `offset` being where they start in the frame's payload.
void applyMask(char* data, size_t n, const MaskKey& mask, uint64_t offset) noexcept;
// A whole control frame (close, ping, pong; the payload cut to 125 bytes), masked when given a key.
[[nodiscard]] std::string controlFrame(Opcode op, std::string_view payload,
                                       const MaskKey* mask = nullptr);
// A close frame's payload: the code (big-endian) and the reason, cut to fit 125 bytes.
[[nodiscard]] std::string closePayload(uint16_t code, std::string_view reason);

class FrameReader {
 public:
  // Where the reader delivers.
  class Sink {
   public:
    // Where the next payload bytes go (at least one byte of room).
    virtual std::span<char> room() = 0;
    // `n` unmasked payload bytes were written at the start of room(). False: stop reading.
    virtual bool payload(size_t n) = 0;
    // A whole control frame (ping, pong, close). False: stop reading.
    virtual bool control(Opcode op, std::string_view payload) = 0;
    // Messages mode: the message whose payload came since the last one ended is whole; `op` is
    // its first frame's (text or binary). False: stop reading.
    virtual bool messageEnd(Opcode /*op*/) { return true; }

   protected:
    Sink() = default;
    ~Sink() = default;
    Sink(const Sink&) = default;
    Sink& operator=(const Sink&) = default;
  };

  struct Failure {
    uint16_t code = kCloseProtocolError;  // the close code to send
    std::string why;
  };

  // server: the peer is a client, whose frames must be masked; a client's peer (a server) must
  // not mask. Reads FlowProtocol (binary messages of whole frames).
  explicit FrameReader(bool server) noexcept : server_(server) {}
  // Messages mode: text and binary messages of at most `max_message_bytes` each.
  static FrameReader messages(bool server, uint64_t max_message_bytes) noexcept {
    FrameReader r(server);
    r.max_message_ = max_message_bytes;
    return r;
  }

  // Reads `in`; returns how many bytes it used: all of them unless the sink said stop or the
  // bytes broke the rules (failure() then says why; nothing more is read).
  size_t feed(std::string_view in, Sink& sink);
  [[nodiscard]] const std::optional<Failure>& failure() const noexcept { return failure_; }
  // Whether the bytes so far end on a message boundary (no frame or message begun).
  [[nodiscard]] bool atMessageBoundary() const noexcept {
    return header_have_ == 0 && !in_frame_ && !in_message_;
  }

 private:
  bool headerDone();  // checks the header read; false on failure
  void fail(uint16_t code, std::string why);
  void walkFlow(const char* data, size_t n) noexcept;  // FlowProtocol length prefixes

  bool server_;
  std::array<uint8_t, kMaxHeaderBytes> header_{};
  size_t header_have_ = 0;
  size_t header_need_ = 2;
  bool in_frame_ = false;    // a header was read, its payload is being read
  bool in_message_ = false;  // a data message was begun and its last frame not finished
  Opcode op_ = Opcode::binary;
  Opcode message_op_ = Opcode::binary;  // the current message's first opcode
  uint64_t max_message_ = 0;            // messages mode when non-zero
  uint64_t message_bytes_ = 0;          // the current message's payload so far, headers read
  bool fin_ = true;
  bool masked_ = false;
  MaskKey mask_{};
  uint64_t left_ = 0;    // payload bytes of the current frame not read yet
  uint64_t offset_ = 0;  // payload bytes of the current frame read
  std::array<char, kMaxControlPayload> control_{};
  // FlowProtocol frames across the message's payload: the length prefix's bytes seen, then the
  // frame's bytes left after it.
  std::array<uint8_t, 4> flow_len_{};
  size_t flow_len_have_ = 0;
  uint64_t flow_left_ = 0;
  std::optional<Failure> failure_;
};

}  // namespace skr::flow::ws
