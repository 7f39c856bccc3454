// SPDX-License-Identifier: Apache-2.0
#include <skrobot/runtime/flow/bytes.h>
#include <skrobot/runtime/flow/path_framing.h>

#include <cstring>
#include <functional>

namespace skr::flow::path {
namespace {

std::string frame(Type type, const std::function<void(ByteWriter&)>& body) {
  std::string out(5, '\0');
  ByteWriter w(out);
  body(w);
  const auto n = static_cast<uint32_t>(out.size() - 4);
  std::memcpy(out.data(), &n, 4);
  out[4] = static_cast<char>(type);
  return out;
}

}  // namespace

std::string encode(const Hello& m) {
  return frame(Type::hello, [&](ByteWriter& w) {
    w.u8(m.version);
    w.u8(m.path);
    w.str16(m.channel);
    w.str16(m.token);
  });
}

std::string encode(const Welcome& m) {
  return frame(Type::welcome, [&](ByteWriter& w) {
    w.u16(m.error);
    w.str16(m.message.substr(0, 1000));
  });
}

std::string encodeBye(std::string_view reason) {
  return frame(Type::bye, [&](ByteWriter& w) { w.str16(reason.substr(0, 1000)); });
}

std::string dataHead(uint64_t seq, int64_t capture_ns, size_t payload_bytes) {
  std::string out = frame(Type::data, [&](ByteWriter& w) {
    w.u64(seq);
    w.i64(capture_ns);
  });
  const auto n = static_cast<uint32_t>(out.size() - 4 + payload_bytes);
  std::memcpy(out.data(), &n, 4);
  return out;
}

Next next(std::string_view in, uint32_t max) {
  Next r;
  if (in.size() < 4) return r;
  std::memcpy(&r.announced, in.data(), 4);
  if (r.announced == 0 || r.announced > max) {
    r.status = Next::Status::too_large;
    return r;
  }
  if (in.size() < 4 + size_t(r.announced)) return r;
  r.status = Next::Status::frame;
  r.type = static_cast<uint8_t>(in[4]);
  r.body = in.substr(5, r.announced - 1);
  r.size = 4 + size_t(r.announced);
  return r;
}

std::optional<Hello> decodeHello(std::string_view body) {
  ByteReader r(body);
  Hello m;
  std::string_view channel, token;
  if (!r.u8(m.version) || !r.u8(m.path) || !r.str16(channel) || !r.str16(token) || !r.empty() ||
      m.version != 1) {
    return std::nullopt;
  }
  m.channel = channel;
  m.token = token;
  return m;
}

std::optional<Welcome> decodeWelcome(std::string_view body) {
  ByteReader r(body);
  Welcome m;
  std::string_view message;
  if (!r.u16(m.error) || !r.str16(message) || !r.empty()) return std::nullopt;
  m.message = message;
  return m;
}

std::optional<Data> decodeData(std::string_view body) {
  ByteReader r(body);
  Data m;
  if (!r.u64(m.seq) || !r.i64(m.capture_ns)) return std::nullopt;
  m.payload = r.rest();
  return m;
}

std::optional<std::string> decodeBye(std::string_view body) {
  ByteReader r(body);
  std::string_view reason;
  if (!r.str16(reason) || !r.empty()) return std::nullopt;
  return std::string(reason);
}

}  // namespace skr::flow::path
