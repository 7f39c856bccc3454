// SPDX-License-Identifier: Apache-2.0
// FlowProtocol over WebSocket (RFC 6455) as a layer over another transport (TCP, or TLS for
// wss:), as TlsTransport layers over TCP. Internal to the runtime: the server end comes from
// http::upgrade() (runtime/internal/http_head.h), the client end from the ws:/wss: dialer.
//
// Reads (ws_frame.h's reader): binary messages only, their payload unmasked straight into the
// receiver's buffer (the receiver reads a stream: framing() is frame_messages); a ping is
// answered with a pong at the next message boundary; a close is echoed and ends the transport
// (TransportEnd::Why::peer_closed). A frame against the rules is answered with a close frame of
// the matching code (1002 protocol, 1003 text, 1007 a message that ends inside a FlowProtocol
// frame), logged FLOW-PROTOCOL, and ends the transport (Why::error).
//
// Messages mode (max_message_bytes > 0: a module's subprotocol, http::upgradeMessages): framing()
// is `messages`; text and binary messages of at most that size are reassembled and handed whole
// to message() (textMessage() tells which); writeMessage() sends text too; closeWith() a code.
//
// Writes: each tryWrite()/write() call is one binary message (header and buffers in one gathered
// write below); what the layer below did not take is kept (a copy only under congestion), so
// that messages never interleave. A client masks (a copy of each message, with a random key).
#pragma once

#include "http_head.h"
#include "ws_frame.h"

#include <skrobot/runtime/flow/transport.h>
#include <skrobot/runtime/loop_handles.h>

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace skr::flow::transport {

class WsTransport final : public http::MessageTransport,
                          private Transport::Receiver,
                          private ws::FrameReader::Sink {
 public:
  // Server: `first_output` (the 101) is written before anything else; `already_read` (bytes
  // that came after the request head) is read before what comes from below; `origin` is the
  // request's Origin (PeerIdentity::origin).
  // Client: `first_output` and `already_read` empty; handshake() then does the upgrade.
  // `max_message_bytes` > 0: messages mode (above).
  WsTransport(Loop& loop, std::unique_ptr<Transport> below, bool server, std::string origin = {},
              std::string first_output = {}, std::string already_read = {},
              uint64_t max_message_bytes = 0);
  ~WsTransport() override;

  // Client: sends the upgrade request (GET `path` with `host`, offering `subprotocol`), reads
  // the answer (at most http::kMaxHeadBytes) and checks it, then pauses; `done` gets nothing
  // (open) or why not, from the loop. Bytes that came after the answer are read once start()
  // is called.
  void handshake(std::string_view host, std::string_view path, std::string_view subprotocol,
                 std::function<void(std::optional<TransportEnd>)> done);

  [[nodiscard]] TransportKind kind() const noexcept override { return TransportKind::websocket; }
  [[nodiscard]] Framing framing() const noexcept override {
    return max_message_ != 0 ? Framing::messages : Framing::frame_messages;
  }
  [[nodiscard]] Result<void> start(Transport::Receiver& receiver) override;
  void pause() noexcept override;
  [[nodiscard]] Result<void> resume() override;
  [[nodiscard]] Result<size_t> tryWrite(std::span<const std::string_view> buffers) override;
  [[nodiscard]] Result<void> write(std::span<const std::string_view> buffers) override;
  void close(std::string_view reason) noexcept override;
  [[nodiscard]] PeerIdentity peer() const override;
  // Messages mode.
  [[nodiscard]] bool textMessage() const noexcept override { return text_; }
  [[nodiscard]] Result<void> writeMessage(bool text, std::string_view data) override;
  void closeWith(uint16_t code, std::string_view reason) noexcept override;

 private:
  // The layer below's receiver.
  std::span<char> readBuffer() override;
  void received(size_t n) override;
  void message(std::string_view) override {}
  void written(Result<void> result) override;
  void ended(const TransportEnd& end) override;
  void closed() noexcept override;
  // The frame reader's sink.
  std::span<char> room() override;
  bool payload(size_t n) override;
  bool control(ws::Opcode op, std::string_view payload) override;
  bool messageEnd(ws::Opcode op) override;

  void process();              // the bytes held in in_, through the reader
  void handshakeInput();       // the client's answer head
  void end(TransportEnd why);  // tells the receiver (or the handshake)
  void refuse(uint16_t code, const std::string& why);
  // One message's header (masked for a client; the key in mask_) into header_.
  size_t header(ws::Opcode op, uint64_t length);
  void queueControl(ws::Opcode op, std::string_view payload);
  // Writes `views` (a whole message or control frames) now as far as below takes them and
  // keeps the rest in out_, then hands out_ to a write below. Nothing is sent while a write
  // below is under way: the bytes go to out_.
  [[nodiscard]] Result<void> send(std::span<const std::string_view> views);
  [[nodiscard]] Result<void> pump();

  std::unique_ptr<Transport> below_;
  ws::FrameReader reader_;
  Transport::Receiver* rx_ = nullptr;
  std::function<void(std::optional<TransportEnd>)> handshake_done_;
  std::string key_, subprotocol_;  // client: the handshake's
  std::string origin_;
  std::unique_ptr<char[]> in_;  // bytes from below not read yet: [in_start_, in_end_)
  size_t in_start_ = 0, in_end_ = 0;
  std::string out_;   // whole messages and control frames not handed below yet
  std::string wire_;  // being written below
  std::vector<std::string_view> views_;
  std::array<char, ws::kMaxHeaderBytes> header_{};
  std::string masked_;    // client: a masked copy of a message
  Timer later_;           // process() after start(); a write with nothing left to send
  uint64_t max_message_;  // messages mode when non-zero
  std::string msg_;       // messages mode: the message being reassembled
  size_t msg_len_ = 0;    // its bytes so far, at the start of msg_
  bool text_ = false;     // the message delivered is text
  ws::Opcode out_op_ = ws::Opcode::binary;  // the next message written
  uint16_t close_code_ = ws::kCloseNormal;
  bool server_;
  bool below_writing_ = false;
  bool user_write_ = false;  // a write() waits for its bytes to leave
  bool ended_ = false;
  bool close_sent_ = false;
  bool closing_ = false;
};

}  // namespace skr::flow::transport
