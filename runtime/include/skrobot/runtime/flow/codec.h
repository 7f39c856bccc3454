// SPDX-License-Identifier: Apache-2.0
// Encoding and decoding of the message structs in messages.h.
//
//   std::string out;
//   if (!encode(out, msg::Subscribe{.tag = 7, .chan_id = 3})) ...;   // appends one whole frame
//   Result<msg::Subscribe> s = decode<msg::Subscribe>(body);         // body: after the code byte
//
// decode() reads bytes that came off a socket: it checks every announced length and count
// against the bytes left before allocating, refuses trailing bytes, and bounds Variant nesting.
#pragma once

#include <skrobot/runtime/flow/bytes.h>
#include <skrobot/runtime/flow/messages.h>
#include <skrobot/runtime/result.h>

#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

namespace skr::flow {

class FieldWriter {
 public:
  FieldWriter(std::string& out, ValueEncoding enc) : w_(out), enc_(enc) {}

  bool operator()(uint8_t v) { return w_.u8(v), true; }
  bool operator()(uint16_t v) { return w_.u16(v), true; }
  bool operator()(uint32_t v) { return w_.u32(v), true; }
  bool operator()(uint64_t v) { return w_.u64(v), true; }
  bool operator()(const std::string& s) {
    if (s.size() > 0xFFFF) return false;
    w_.str16(s);
    return true;
  }
  bool operator()(const msg::Text32& t) {
    if (t.text.size() > 0xFFFFFFFFu) return false;
    w_.str32(t.text);
    return true;
  }
  bool operator()(const msg::Rest& r) { return w_.raw(r.bytes), true; }
  bool operator()(const Variant& v) {
    w_.u8(static_cast<uint8_t>(enc_));
    if (enc_ == ValueEncoding::json) {
      w_.str32(variantToJsonText(v));
    } else {
      encodeVariant(v, w_);
    }
    return true;
  }
  // A part shared by several frames (ChannelInfo): its fields in place.
  template <class T>
  requires requires(T& t, FieldWriter& w) { t.io(w); }
  bool operator()(const T& part) { return const_cast<T&>(part).io(*this); }
  template <class T>
  bool operator()(const std::vector<T>& items) {
    w_.u32(static_cast<uint32_t>(items.size()));
    for (const auto& item : items) {
      if (!const_cast<T&>(item).io(*this)) return false;
    }
    return true;
  }

 private:
  ByteWriter w_;
  ValueEncoding enc_;
};

class FieldReader {
 public:
  FieldReader(std::string_view body, const DecodeLimits& limits) : r_(body), limits_(limits) {}

  bool operator()(uint8_t& v) { return r_.u8(v) || fail("u8"); }
  bool operator()(uint16_t& v) { return r_.u16(v) || fail("u16"); }
  bool operator()(uint32_t& v) { return r_.u32(v) || fail("u32"); }
  bool operator()(uint64_t& v) { return r_.u64(v) || fail("u64"); }
  bool operator()(std::string& s) {
    std::string_view v;
    if (!r_.str16(v)) return fail("str16");
    s.assign(v);
    return true;
  }
  bool operator()(msg::Text32& t) {
    std::string_view v;
    if (!r_.str32(v)) return fail("str32");
    t.text.assign(v);
    return true;
  }
  bool operator()(msg::Rest& r) {
    r.bytes = r_.rest();
    return true;
  }
  bool operator()(Variant& v);
  template <class T>
  requires requires(T& t, FieldReader& r) { t.io(r); }
  bool operator()(T& part) { return part.io(*this); }
  template <class T>
  bool operator()(std::vector<T>& items) {
    uint32_t count = 0;
    if (!r_.u32(count)) return fail("count");
    if (count > r_.remaining()) {
      return failWith("count " + std::to_string(count) + " exceeds the " +
                      std::to_string(r_.remaining()) + " bytes left");
    }
    items.clear();
    items.reserve(count);
    for (uint32_t i = 0; i < count; ++i) {
      if (!items.emplace_back().io(*this)) return false;
    }
    return true;
  }

  [[nodiscard]] bool atEnd() const noexcept { return r_.empty(); }
  [[nodiscard]] size_t remaining() const noexcept { return r_.remaining(); }
  [[nodiscard]] const std::string& error() const noexcept { return error_; }
  bool failWith(std::string why) {
    if (error_.empty()) error_ = std::move(why);
    return false;
  }

 private:
  bool fail(const char* what) {
    return failWith(std::string("truncated: no room for ") + what + " (" +
                    std::to_string(r_.remaining()) + " bytes left)");
  }
  ByteReader r_;
  DecodeLimits limits_;
  std::string error_;
};

// Appends one whole frame (header + body). False when a field exceeds its wire limit (a str16
// longer than 65535 bytes); `out` is then left as it was.
template <class M>
[[nodiscard]] bool encode(std::string& out, const M& m, ValueEncoding enc = ValueEncoding::binary) {
  const size_t start = out.size();
  appendHeader(out, M::code, 0);
  FieldWriter w(out, enc);
  if (!const_cast<M&>(m).io(w)) {
    out.resize(start);
    return false;
  }
  ByteWriter(out).patchU32(start, static_cast<uint32_t>(out.size() - start - 4));
  return true;
}

// Decodes a frame body (the bytes after the code). Errc::protocol_error with the reason.
template <class M>
[[nodiscard]] Result<M> decode(std::string_view body, const DecodeLimits& limits = {}) {
  M m{};
  FieldReader r(body, limits);
  if (!m.io(r)) {
    return makeError(Errc::protocol_error,
                     std::string(codeName(static_cast<uint8_t>(M::code))) + ": " + r.error());
  }
  if (!r.atEnd()) {
    return makeError(Errc::protocol_error, std::string(codeName(static_cast<uint8_t>(M::code))) +
                                               ": " + std::to_string(r.remaining()) +
                                               " trailing bytes");
  }
  return m;
}

}  // namespace skr::flow
