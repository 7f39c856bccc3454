// SPDX-License-Identifier: Apache-2.0
#include "qi_message.h"

#include <cstring>

namespace skr::nao::qi {
namespace {

template <class T>
void put(std::string& out, T v) {
  char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  out.append(b, sizeof(T));
}
template <class T>
T get(std::string_view b, std::size_t at) {
  T v;
  std::memcpy(&v, b.data() + at, sizeof(T));
  return v;
}

}  // namespace

std::string encodeMessage(Header h, std::string_view payload) {
  std::string out;
  out.reserve(kHeaderSize + payload.size());
  out.push_back(static_cast<char>(kMagic >> 24));
  out.push_back(static_cast<char>((kMagic >> 16) & 0xff));
  out.push_back(static_cast<char>((kMagic >> 8) & 0xff));
  out.push_back(static_cast<char>(kMagic & 0xff));
  put(out, h.id);
  put(out, static_cast<std::uint32_t>(payload.size()));
  put(out, h.version);
  put(out, static_cast<std::uint8_t>(h.type));
  put(out, h.flags);
  put(out, h.service);
  put(out, h.object);
  put(out, h.action);
  out.append(payload);
  return out;
}

Result<Header> parseHeader(std::string_view b, std::uint32_t max_payload) {
  if (b.size() < kHeaderSize) return makeError(Errc::protocol_error, "short header");
  const auto* u = reinterpret_cast<const unsigned char*>(b.data());
  const std::uint32_t magic = (std::uint32_t{u[0]} << 24) | (std::uint32_t{u[1]} << 16) |
                              (std::uint32_t{u[2]} << 8) | std::uint32_t{u[3]};
  if (magic != kMagic) return makeError(Errc::protocol_error, "bad magic (not a qi stream)");
  Header h;
  h.id = get<std::uint32_t>(b, 4);
  h.size = get<std::uint32_t>(b, 8);
  h.version = get<std::uint16_t>(b, 12);
  const auto type = get<std::uint8_t>(b, 14);
  h.flags = get<std::uint8_t>(b, 15);
  h.service = get<std::uint32_t>(b, 16);
  h.object = get<std::uint32_t>(b, 20);
  h.action = get<std::uint32_t>(b, 24);
  if (h.version != 0) {
    return makeError(Errc::protocol_error,
                     "unsupported header version " + std::to_string(h.version));
  }
  if (type == 0 || type > static_cast<std::uint8_t>(MsgType::cancelled)) {
    return makeError(Errc::protocol_error, "unknown message type " + std::to_string(type));
  }
  h.type = static_cast<MsgType>(type);
  if (h.size > max_payload) {
    return makeError(Errc::protocol_error, "message of " + std::to_string(h.size) +
                                               " bytes exceeds the limit of " +
                                               std::to_string(max_payload));
  }
  return h;
}

Result<std::optional<Message>> MessageFramer::next() {
  if (buf_.size() < kHeaderSize) return std::optional<Message>();
  auto h = parseHeader(buf_, max_payload_);
  if (!h) return h.error();
  if (buf_.size() - kHeaderSize < h->size) return std::optional<Message>();
  Message m{h.value(), buf_.substr(kHeaderSize, h->size)};
  buf_.erase(0, kHeaderSize + h->size);
  return std::optional<Message>(std::move(m));
}

}  // namespace skr::nao::qi
