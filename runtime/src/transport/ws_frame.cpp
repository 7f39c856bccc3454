// SPDX-License-Identifier: Apache-2.0
#include "ws_frame.h"

#include <algorithm>
#include <cstring>

namespace skr::flow::ws {

size_t writeHeader(char* out, Opcode op, bool fin, uint64_t length, const MaskKey* mask) noexcept {
  auto* o = reinterpret_cast<uint8_t*>(out);
  o[0] = static_cast<uint8_t>((fin ? 0x80 : 0) | static_cast<uint8_t>(op));
  const uint8_t m = mask != nullptr ? 0x80 : 0;
  size_t n = 2;
  if (length < 126) {
    o[1] = static_cast<uint8_t>(m | length);
  } else if (length <= 0xFFFF) {
    o[1] = m | 126;
    o[2] = static_cast<uint8_t>(length >> 8);
    o[3] = static_cast<uint8_t>(length);
    n = 4;
  } else {
    o[1] = m | 127;
    for (int i = 0; i < 8; ++i) o[2 + i] = static_cast<uint8_t>(length >> (56 - 8 * i));
    n = 10;
  }
  if (mask != nullptr) {
    std::memcpy(o + n, mask->data(), 4);
    n += 4;
  }
  return n;
}

void applyMask(char* data, size_t n, const MaskKey& mask, uint64_t offset) noexcept {
  // Eight bytes at a time: every 8-byte step starts at the same place in the 4-byte key, so one
  // word of the key, rotated to `offset`, masks them all (a client's 64 KiB message: 8 K XORs).
  std::array<uint8_t, 8> rotated{};
  for (size_t j = 0; j < rotated.size(); ++j) rotated[j] = mask[(offset + j) & 3];
  uint64_t key = 0;
  std::memcpy(&key, rotated.data(), sizeof key);
  size_t i = 0;
  for (; i + sizeof key <= n; i += sizeof key) {
    uint64_t word = 0;
    std::memcpy(&word, data + i, sizeof word);
    word ^= key;
    std::memcpy(data + i, &word, sizeof word);
  }
  for (; i < n; ++i) data[i] = static_cast<char>(data[i] ^ mask[(offset + i) & 3]);
}

std::string controlFrame(Opcode op, std::string_view payload, const MaskKey* mask) {
  payload = payload.substr(0, kMaxControlPayload);
  std::string frame(kMaxHeaderBytes, '\0');
  frame.resize(writeHeader(frame.data(), op, true, payload.size(), mask));
  const size_t at = frame.size();
  frame.append(payload);
  if (mask != nullptr) applyMask(frame.data() + at, payload.size(), *mask, 0);
  return frame;
}

std::string closePayload(uint16_t code, std::string_view reason) {
  std::string p;
  p.push_back(static_cast<char>(code >> 8));
  p.push_back(static_cast<char>(code & 0xFF));
  p.append(reason.substr(0, kMaxControlPayload - 2));
  return p;
}

void FrameReader::fail(uint16_t code, std::string why) {
  failure_ = Failure{code, std::move(why)};
}

bool FrameReader::headerDone() {
  const uint8_t b0 = header_[0];
  const uint8_t b1 = header_[1];
  if (header_need_ == 2) {  // the length's and the mask's sizes are known now
    const uint8_t len7 = b1 & 0x7F;
    header_need_ += len7 == 126 ? 2 : len7 == 127 ? 8 : 0;
    header_need_ += (b1 & 0x80) != 0 ? 4 : 0;
    if (header_need_ > 2) return true;  // read the rest first
  }
  if ((b0 & 0x70) != 0) {
    fail(kCloseProtocolError, "RSV bits set (no extension was agreed)");
    return false;
  }
  const uint8_t op = b0 & 0x0F;
  fin_ = (b0 & 0x80) != 0;
  masked_ = (b1 & 0x80) != 0;
  if (masked_ != server_) {
    fail(kCloseProtocolError,
         server_ ? "an unmasked frame from a client" : "a masked frame from a server");
    return false;
  }
  const uint8_t len7 = b1 & 0x7F;
  size_t at = 2;
  if (len7 == 126) {
    left_ = (uint64_t{header_[2]} << 8) | header_[3];
    at = 4;
  } else if (len7 == 127) {
    left_ = 0;
    for (int i = 0; i < 8; ++i) left_ = (left_ << 8) | header_[2 + i];
    at = 10;
    if ((left_ >> 63) != 0) {
      fail(kCloseProtocolError, "a 64-bit payload length with its top bit set");
      return false;
    }
  } else {
    left_ = len7;
  }
  if (masked_) std::memcpy(mask_.data(), header_.data() + at, 4);
  offset_ = 0;
  switch (op) {
    case static_cast<uint8_t>(Opcode::text):
      if (max_message_ == 0) {
        fail(kCloseUnsupportedData, "a text message (FlowProtocol travels in binary messages)");
        return false;
      }
      [[fallthrough]];
    case static_cast<uint8_t>(Opcode::binary):
      if (in_message_) {
        fail(kCloseProtocolError, "a new message began before the last one's final fragment");
        return false;
      }
      in_message_ = true;
      message_op_ = static_cast<Opcode>(op);
      message_bytes_ = 0;
      break;
    case static_cast<uint8_t>(Opcode::continuation):
      if (!in_message_) {
        fail(kCloseProtocolError, "a continuation frame outside a message");
        return false;
      }
      break;
    case static_cast<uint8_t>(Opcode::close):
    case static_cast<uint8_t>(Opcode::ping):
    case static_cast<uint8_t>(Opcode::pong):
      if (!fin_ || left_ > kMaxControlPayload) {
        fail(kCloseProtocolError, "a fragmented control frame or one over 125 bytes");
        return false;
      }
      if (op == static_cast<uint8_t>(Opcode::close) && left_ == 1) {
        fail(kCloseProtocolError, "a close frame of 1 byte");
        return false;
      }
      break;
    default:
      fail(kCloseProtocolError, "unknown opcode " + std::to_string(op));
      return false;
  }
  op_ = static_cast<Opcode>(op);
  if (max_message_ != 0 &&
      (op_ == Opcode::text || op_ == Opcode::binary || op_ == Opcode::continuation)) {
    // Refused on the header, before any of the payload is read or kept.
    if (left_ > max_message_ - message_bytes_) {
      fail(kCloseMessageTooBig,
           "a message of more than " + std::to_string(max_message_) + " bytes");
      return false;
    }
    message_bytes_ += left_;
  }
  header_have_ = 0;
  header_need_ = 2;
  in_frame_ = true;
  return true;
}

void FrameReader::walkFlow(const char* data, size_t n) noexcept {
  while (n > 0) {
    if (flow_left_ > 0) {
      const uint64_t take = std::min<uint64_t>(flow_left_, n);
      flow_left_ -= take;
      data += take;
      n -= static_cast<size_t>(take);
      continue;
    }
    flow_len_[flow_len_have_++] = static_cast<uint8_t>(*data++);
    --n;
    if (flow_len_have_ == 4) {  // little-endian, as every FlowProtocol integer
      flow_left_ = uint64_t{flow_len_[0]} | uint64_t{flow_len_[1]} << 8 |
                   uint64_t{flow_len_[2]} << 16 | uint64_t{flow_len_[3]} << 24;
      flow_len_have_ = 0;
    }
  }
}

size_t FrameReader::feed(std::string_view in, Sink& sink) {
  size_t used = 0;
  while (!failure_) {
    if (!in_frame_) {
      if (used == in.size()) break;
      while (header_have_ < header_need_ && used < in.size()) {
        header_[header_have_++] = static_cast<uint8_t>(in[used++]);
      }
      if (header_have_ < header_need_) break;
      if (!headerDone()) break;
      if (!in_frame_) continue;  // the rest of the header
    }
    const bool control =
        op_ != Opcode::binary && op_ != Opcode::continuation && op_ != Opcode::text;
    if (control) {
      const auto take = static_cast<size_t>(std::min<uint64_t>(left_, in.size() - used));
      std::memcpy(control_.data() + offset_, in.data() + used, take);
      used += take;
      offset_ += take;
      left_ -= take;
      if (left_ > 0) break;
      if (masked_) applyMask(control_.data(), static_cast<size_t>(offset_), mask_, 0);
      in_frame_ = false;
      if (!sink.control(op_, {control_.data(), static_cast<size_t>(offset_)})) break;
      continue;
    }
    while (left_ > 0 && used < in.size()) {
      const std::span<char> room = sink.room();
      const auto take = static_cast<size_t>(
          std::min<uint64_t>({left_, in.size() - used, static_cast<uint64_t>(room.size())}));
      std::memcpy(room.data(), in.data() + used, take);
      if (masked_) applyMask(room.data(), take, mask_, offset_);
      if (max_message_ == 0) walkFlow(room.data(), take);
      used += take;
      offset_ += take;
      left_ -= take;
      if (!sink.payload(take)) return used;
    }
    if (left_ > 0) break;
    in_frame_ = false;
    if (fin_) {
      in_message_ = false;
      if (max_message_ != 0) {
        if (!sink.messageEnd(message_op_)) return used;
      } else if (flow_len_have_ != 0 || flow_left_ != 0) {
        fail(kCloseInvalidPayload, "a WebSocket message ended inside a frame");
        break;
      }
    }
  }
  return used;
}

}  // namespace skr::flow::ws
