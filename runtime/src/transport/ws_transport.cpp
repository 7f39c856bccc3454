// SPDX-License-Identifier: Apache-2.0
#include "ws_transport.h"

#include "http_head.h"

#include <skrobot/runtime/log.h>
#include <skrobot/base64.hpp>

#include <openssl/rand.h>

#include <cstring>

namespace skr::flow::transport {
namespace {

constexpr size_t kInChunk = size_t{64} * 1024;

ws::MaskKey randomMask() {
  ws::MaskKey k{};
  if (RAND_bytes(k.data(), static_cast<int>(k.size())) != 1) {
    // Masking guards proxies against a page's chosen bytes; a client that cannot draw a key
    // still sends a valid frame.
    k = {0x5A, 0xA5, 0x3C, 0xC3};
  }
  return k;
}

size_t total(std::span<const std::string_view> buffers) noexcept {
  size_t n = 0;
  for (const std::string_view b : buffers) n += b.size();
  return n;
}

}  // namespace

WsTransport::WsTransport(Loop& loop, std::unique_ptr<Transport> below, bool server,
                         std::string origin, std::string first_output, std::string already_read,
                         uint64_t max_message_bytes)
    : below_(std::move(below)),
      reader_(max_message_bytes != 0 ? ws::FrameReader::messages(server, max_message_bytes)
                                     : ws::FrameReader(server)),
      origin_(std::move(origin)),
      in_(std::make_unique_for_overwrite<char[]>(std::max(kInChunk, already_read.size()))),
      out_(std::move(first_output)),
      later_(loop,
             [this] {
               if (user_write_ && !below_writing_ && out_.empty()) {
                 user_write_ = false;
                 rx_->written({});
               }
               process();
             }),
      max_message_(max_message_bytes),
      server_(server) {
  std::memcpy(in_.get(), already_read.data(), already_read.size());
  in_end_ = already_read.size();
}

WsTransport::~WsTransport() = default;

void WsTransport::handshake(std::string_view host, std::string_view path,
                            std::string_view subprotocol,
                            std::function<void(std::optional<TransportEnd>)> done) {
  handshake_done_ = std::move(done);
  std::array<uint8_t, 16> nonce{};
  if (RAND_bytes(nonce.data(), static_cast<int>(nonce.size())) != 1) {
    end({TransportEnd::Why::error, "no random bytes for the WebSocket key"});
    return;
  }
  key_ = base64::encode({reinterpret_cast<const char*>(nonce.data()), nonce.size()});
  subprotocol_ = std::string(subprotocol);
  out_ = http::clientRequest(host, path, key_, subprotocol_);
  if (auto r = below_->start(*this); !r) {
    end({TransportEnd::Why::error, r.error().message});
    return;
  }
  if (auto r = send({}); !r) end({TransportEnd::Why::error, r.error().message});
}

Result<void> WsTransport::start(Transport::Receiver& receiver) {
  rx_ = &receiver;
  if (in_end_ > in_start_) later_.startIn(0);  // what came with the head
  if (auto r = server_ ? below_->start(*this) : below_->resume(); !r) return r;
  return send({});  // the 101
}

void WsTransport::pause() noexcept {
  below_->pause();
}

Result<void> WsTransport::resume() {
  return below_->resume();
}

std::span<char> WsTransport::readBuffer() {
  if (in_start_ == in_end_) in_start_ = in_end_ = 0;
  if (in_end_ == kInChunk && in_start_ > 0) {  // the client's handshake head left a tail
    std::memmove(in_.get(), in_.get() + in_start_, in_end_ - in_start_);
    in_end_ -= in_start_;
    in_start_ = 0;
  }
  return {in_.get() + in_end_, kInChunk - in_end_};
}

void WsTransport::received(size_t n) {
  in_end_ += n;
  if (handshake_done_) {
    handshakeInput();
    return;
  }
  process();
}

void WsTransport::handshakeInput() {
  const std::string_view got(in_.get() + in_start_, in_end_ - in_start_);
  const size_t head = http::headEnd(got);
  if (head == 0) {
    if (got.size() >= http::kMaxHeadBytes) {
      end({TransportEnd::Why::refused, "the WebSocket server's answer head is over 8 KiB"});
    }
    return;
  }
  auto response = http::parseResponse(got.substr(0, head));
  if (!response) {
    end({TransportEnd::Why::refused, "the WebSocket server's answer: " + response.error().message});
    return;
  }
  if (auto bad = http::checkAccepted(*response, key_, subprotocol_)) {
    end({TransportEnd::Why::refused, *bad});
    return;
  }
  in_start_ += head;
  below_->pause();
  auto done = std::move(handshake_done_);
  handshake_done_ = nullptr;
  done(std::nullopt);
}

void WsTransport::process() {
  while (rx_ != nullptr && !ended_ && !closing_ && in_start_ < in_end_) {
    const std::string_view bytes(in_.get() + in_start_, in_end_ - in_start_);
    const size_t used = reader_.feed(bytes, *this);
    in_start_ += used;
    if (const auto& f = reader_.failure()) {
      refuse(f->code, f->why);
      return;
    }
    if (used == 0) return;
  }
}

std::span<char> WsTransport::room() {
  if (max_message_ == 0) return rx_->readBuffer();
  // The reader checked the message's frames against the limit: it never asks past it.
  if (msg_len_ == msg_.size()) {
    msg_.resize(static_cast<size_t>(
        std::min<uint64_t>(max_message_, std::max<size_t>(msg_.size() * 2, 4096))));
  }
  return {msg_.data() + msg_len_, msg_.size() - msg_len_};
}

bool WsTransport::payload(size_t n) {
  if (max_message_ != 0) {
    msg_len_ += n;
    return true;
  }
  rx_->received(n);  // may close this transport
  return !ended_ && !closing_;
}

bool WsTransport::messageEnd(ws::Opcode op) {
  text_ = op == ws::Opcode::text;
  const size_t n = msg_len_;
  msg_len_ = 0;
  rx_->message({msg_.data(), n});                        // may close this transport
  if (msg_.size() > kInChunk) std::string().swap(msg_);  // a large message's room goes
  return !ended_ && !closing_;
}

bool WsTransport::control(ws::Opcode op, std::string_view payload) {
  if (op == ws::Opcode::ping) {
    queueControl(ws::Opcode::pong, payload);
    return true;
  }
  if (op != ws::Opcode::close) return true;  // a pong
  uint16_t code = ws::kCloseNormal;
  std::string text = "the peer closed the WebSocket";
  if (payload.size() >= 2) {
    code = static_cast<uint16_t>(static_cast<uint8_t>(payload[0]) << 8 |
                                 static_cast<uint8_t>(payload[1]));
    text += " (" + std::to_string(code);
    if (payload.size() > 2) text += " " + std::string(payload.substr(2));
    text += ")";
  }
  if (!close_sent_) {
    close_sent_ = true;
    queueControl(ws::Opcode::close, payload.substr(0, 2));  // the echo
  }
  end({TransportEnd::Why::peer_closed, text});
  return false;
}

void WsTransport::queueControl(ws::Opcode op, std::string_view payload) {
  const ws::MaskKey mask = randomMask();
  const std::string frame = ws::controlFrame(op, payload, server_ ? nullptr : &mask);
  const std::string_view f = frame;
  if (auto r = send({&f, 1}); !r) end({TransportEnd::Why::error, r.error().message});
}

void WsTransport::refuse(uint16_t code, const std::string& why) {
  log::warn("flow", "FLOW-PROTOCOL",
            peer().source() + ": " + why + " (close " + std::to_string(code) + ")");
  if (!close_sent_ && !below_writing_ && out_.empty()) {
    close_sent_ = true;
    queueControl(ws::Opcode::close, ws::closePayload(code, why));
  }
  end({TransportEnd::Why::error, "WebSocket: " + why});
}

void WsTransport::end(TransportEnd why) {
  if (ended_ || closing_) return;
  ended_ = true;
  below_->pause();
  if (handshake_done_) {
    auto done = std::move(handshake_done_);
    handshake_done_ = nullptr;
    done(std::move(why));
  } else if (rx_ != nullptr) {
    rx_->ended(why);
  }
}

void WsTransport::ended(const TransportEnd& e) {
  if (handshake_done_ && e.why == TransportEnd::Why::peer_closed) {
    end({TransportEnd::Why::peer_closed,
         "the server closed the connection before answering the WebSocket upgrade"});
    return;
  }
  end(e);
}

size_t WsTransport::header(ws::Opcode op, uint64_t length) {
  if (server_) return ws::writeHeader(header_.data(), op, true, length);
  const ws::MaskKey mask = randomMask();
  return ws::writeHeader(header_.data(), op, true, length, &mask);
}

Result<void> WsTransport::send(std::span<const std::string_view> views) {
  if (below_writing_ || !out_.empty()) {
    for (const std::string_view v : views) out_.append(v);
    return pump();
  }
  if (views.empty()) return {};
  auto sent = below_->tryWrite(views);
  if (!sent) return sent.error();
  size_t skip = *sent;
  for (const std::string_view v : views) {
    if (skip >= v.size()) {
      skip -= v.size();
      continue;
    }
    out_.append(v.substr(skip));
    skip = 0;
  }
  return pump();
}

Result<void> WsTransport::pump() {
  if (below_writing_ || out_.empty()) return {};
  wire_.swap(out_);
  out_.clear();
  below_writing_ = true;
  const std::string_view w = wire_;
  if (auto r = below_->write({&w, 1}); !r) {
    below_writing_ = false;
    return r;
  }
  return {};
}

void WsTransport::written(Result<void> result) {
  below_writing_ = false;
  wire_.clear();
  views_.clear();
  if (closing_) return;
  if (!result) {
    if (user_write_) {
      user_write_ = false;
      rx_->written(std::move(result));
    } else {
      end({TransportEnd::Why::error, result.error().message});
    }
    return;
  }
  if (handshake_done_) {
    if (auto r = pump(); !r) end({TransportEnd::Why::error, r.error().message});
    return;
  }
  if (user_write_ && out_.empty()) {
    user_write_ = false;
    rx_->written({});  // may close this transport
    if (closing_) return;
  }
  if (auto r = pump(); !r) end({TransportEnd::Why::error, r.error().message});
}

Result<size_t> WsTransport::tryWrite(std::span<const std::string_view> buffers) {
  if (closing_ || ended_) return makeError(Errc::io_error, "closed");
  if (below_writing_ || user_write_) return size_t{0};
  const size_t n = total(buffers);
  const size_t h = header(out_op_, n);
  views_.clear();
  views_.emplace_back(header_.data(), h);
  if (server_) {
    views_.insert(views_.end(), buffers.begin(), buffers.end());
  } else {
    masked_.clear();
    for (const std::string_view b : buffers) masked_.append(b);
    ws::MaskKey mask{};
    std::memcpy(mask.data(), header_.data() + h - 4, 4);
    ws::applyMask(masked_.data(), masked_.size(), mask, 0);
    views_.emplace_back(masked_);
  }
  auto r = send(views_);
  views_.clear();
  if (!r) return r.error();
  return n;  // the whole message: what below did not take leaves with a write below
}

Result<void> WsTransport::write(std::span<const std::string_view> buffers) {
  if (closing_ || ended_) return makeError(Errc::io_error, "closed");
  if (user_write_) return makeError(Errc::internal, "a write is under way");
  if (server_ && !below_writing_ && out_.empty()) {
    // The buffers as they are, behind the header: they stay valid until written().
    views_.clear();
    views_.emplace_back(header_.data(), header(out_op_, total(buffers)));
    views_.insert(views_.end(), buffers.begin(), buffers.end());
    below_writing_ = true;
    user_write_ = true;
    if (auto r = below_->write(views_); !r) {
      below_writing_ = user_write_ = false;
      views_.clear();
      return r;
    }
    return {};
  }
  // Behind what waits (or masked, for a client): a copy, handed below once it may.
  const size_t n = total(buffers);
  const size_t h = header(out_op_, n);
  const size_t at = out_.size() + h;
  out_.append(header_.data(), h);
  for (const std::string_view b : buffers) out_.append(b);
  if (!server_) {
    ws::MaskKey mask{};
    std::memcpy(mask.data(), header_.data() + h - 4, 4);
    ws::applyMask(out_.data() + at, n, mask, 0);
  }
  user_write_ = true;
  if (auto r = pump(); !r) {
    user_write_ = false;
    return r;
  }
  return {};
}

void WsTransport::close(std::string_view reason) noexcept {
  if (closing_) return;
  closing_ = true;
  later_.stop();
  if (!close_sent_ && !ended_ && !handshake_done_ && rx_ != nullptr && !below_writing_ &&
      out_.empty()) {
    // A close frame, so that the peer can tell our close from a cut connection.
    close_sent_ = true;
    const ws::MaskKey mask = randomMask();
    const std::string frame = ws::controlFrame(
        ws::Opcode::close, ws::closePayload(close_code_, reason), server_ ? nullptr : &mask);
    const std::string_view f = frame;
    (void)below_->tryWrite({&f, 1});
  }
  below_->close(reason);
}

void WsTransport::closed() noexcept {
  if (rx_ != nullptr) rx_->closed();  // may destroy this
}

Result<void> WsTransport::writeMessage(bool text, std::string_view data) {
  out_op_ = text ? ws::Opcode::text : ws::Opcode::binary;
  auto r = write({&data, 1});
  out_op_ = ws::Opcode::binary;
  return r;
}

void WsTransport::closeWith(uint16_t code, std::string_view reason) noexcept {
  close_code_ = code;
  close(reason);
}

PeerIdentity WsTransport::peer() const {
  PeerIdentity id = below_->peer();
  id.kind = TransportKind::websocket;
  id.origin = origin_;
  return id;
}

}  // namespace skr::flow::transport
