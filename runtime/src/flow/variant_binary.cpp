// SPDX-License-Identifier: Apache-2.0
// The binary encoding of Variant (docs/flow-protocol.md). The decoder reads untrusted bytes: it
// trusts no announced length or count until it has compared it with the bytes left.
#include <skrobot/runtime/flow/variant.h>

#include <algorithm>
#include <cstdio>
#include <limits>

namespace skr::flow {
namespace {

using Type = Variant::Type;

std::string hexByte(uint8_t b) {
  char buf[8];
  std::snprintf(buf, sizeof buf, "0x%02x", b);
  return buf;
}

// A key for an error message: quoted, control characters escaped, at most 64 bytes.
std::string quoteKey(std::string_view key) {
  std::string out = "\"";
  for (size_t i = 0; i < key.size() && i < 64; ++i) {
    const auto c = static_cast<unsigned char>(key[i]);
    if (c == '"' || c == '\\') {
      out += '\\';
      out += static_cast<char>(c);
    } else if (c < 0x20 || c == 0x7F) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\x%02x", c);
      out += buf;
    } else {
      out += static_cast<char>(c);
    }
  }
  if (key.size() > 64) out += "...";
  return out + "\"";
}

// Reserving is only a speed-up; bounding it keeps a nest of lists that each announce many
// elements from reserving memory the input never fills.
constexpr size_t kMaxReserve = 1024;

class Decoder {
 public:
  Decoder(ByteReader in, size_t max_depth, bool capped, size_t max_bytes)
      : r_(in),
        start_(in.position()),
        max_depth_(max_depth),
        capped_(capped),
        max_bytes_(max_bytes) {}

  Result<Variant> value(size_t depth) {
    if (depth > max_depth_) {
      return fail("variant at depth " + std::to_string(depth) + " exceeds the limit of " +
                  std::to_string(max_depth_));
    }
    uint8_t tag = 0;
    if (!r_.u8(tag)) return truncated("tag", 1);
    switch (static_cast<Type>(tag)) {
      case Type::null:
        return Variant();
      case Type::boolean: {
        uint8_t b = 0;
        if (!r_.u8(b)) return truncated("bool", 1);
        if (b > 1) return fail("bad bool byte " + hexByte(b), offset() - 1);
        return Variant(b == 1);
      }
      case Type::int64: {
        int64_t i = 0;
        if (!r_.i64(i)) return truncated("int64", 8);
        return Variant(i);
      }
      case Type::uint64: {
        uint64_t u = 0;
        if (!r_.u64(u)) return truncated("uint64", 8);
        return Variant(u);
      }
      case Type::float64: {
        double d = 0;
        if (!r_.f64(d)) return truncated("float64", 8);
        return Variant(d);
      }
      case Type::string: {
        std::string_view s;
        if (!text("string", s)) return std::move(error_);
        if (!isValidUtf8(s)) return fail("string is not valid UTF-8", offset() - s.size());
        return Variant(std::string(s));
      }
      case Type::bytes: {
        std::string_view s;
        if (!text("bytes", s)) return std::move(error_);
        return Variant(Variant::Bytes(std::string(s)));
      }
      case Type::list:
        return list(depth);
      case Type::map:
        return map(depth);
    }
    return fail("unknown variant tag " + hexByte(tag), offset() - 1);
  }

  [[nodiscard]] size_t consumed() const noexcept { return offset(); }

 private:
  [[nodiscard]] size_t offset() const noexcept {
    return static_cast<size_t>(r_.position() - start_);
  }

  Error fail(const std::string& why, size_t at) {
    return makeError(Errc::protocol_error, why + " (at byte " + std::to_string(at) + ")");
  }
  Error fail(const std::string& why) { return fail(why, offset()); }

  // What is left, for messages: the value size limit may be what cut the input short.
  [[nodiscard]] std::string bytesLeft() const {
    std::string s = std::to_string(r_.remaining()) + " bytes left";
    if (capped_) s += " under the value size limit of " + std::to_string(max_bytes_);
    return s;
  }

  // Reading `what` (at least `need` bytes) at `at` ran out of input.
  Error truncated(const std::string& what, size_t need, size_t at) {
    return fail("truncated: " + what + " needs " + std::to_string(need) +
                    (need == 1 ? " byte, " : " bytes, ") + bytesLeft(),
                at);
  }
  Error truncated(const std::string& what, size_t need) { return truncated(what, need, offset()); }

  // u32 length + that many bytes, the length checked against what is left.
  bool text(const char* what, std::string_view& out) {
    uint32_t n = 0;
    if (!r_.u32(n)) {
      error_ = truncated(std::string(what) + " length", 4);
      return false;
    }
    if (n > r_.remaining()) {
      error_ =
          fail(std::string(what) + " length " + std::to_string(n) + " exceeds the " + bytesLeft(),
               offset() - 4);
      return false;
    }
    return r_.view(n, out);
  }

  // u32 count, each element taking at least `min_bytes`.
  bool count(const char* what, size_t min_bytes, uint32_t& n) {
    if (!r_.u32(n)) {
      error_ = truncated(what, 4);
      return false;
    }
    if (n > r_.remaining() / min_bytes) {
      error_ = fail(std::string(what) + " " + std::to_string(n) + " exceeds the " + bytesLeft() +
                        " (each element takes at least " + std::to_string(min_bytes) +
                        (min_bytes == 1 ? " byte)" : " bytes)"),
                    offset() - 4);
      return false;
    }
    return true;
  }

  Result<Variant> list(size_t depth) {
    uint32_t n = 0;
    if (!count("list count", 1, n)) return std::move(error_);
    Variant::List items;
    items.reserve(std::min<size_t>(n, kMaxReserve));
    for (uint32_t i = 0; i < n; ++i) {
      Result<Variant> item = value(depth + 1);
      if (!item) return item.error();
      items.push_back(std::move(item).value());
    }
    return Variant(std::move(items));
  }

  Result<Variant> map(size_t depth) {
    uint32_t n = 0;
    if (!count("map count", 3, n)) return std::move(error_);  // u16 key length + a tag
    Variant::Map entries;
    for (uint32_t i = 0; i < n; ++i) {
      const size_t key_at = offset();
      std::string_view key;
      if (!r_.str16(key)) return truncated("map key (u16 length + bytes)", 2, key_at);
      if (!isValidUtf8(key)) return fail("map key is not valid UTF-8", key_at + 2);
      if (entries.contains(key)) return fail("duplicate map key " + quoteKey(key), key_at);
      Result<Variant> item = value(depth + 1);
      if (!item) return item.error();
      entries.emplace_hint(entries.end(), std::string(key), std::move(item).value());
    }
    return Variant(std::move(entries));
  }

  ByteReader r_;
  const uint8_t* start_;
  size_t max_depth_;
  bool capped_;
  size_t max_bytes_;
  Error error_;
};

void encodeTo(const Variant& v, ByteWriter& w) {
  w.u8(static_cast<uint8_t>(v.type()));
  switch (v.type()) {
    case Type::null:
      return;
    case Type::boolean:
      w.u8(*v.asBool() ? 1 : 0);
      return;
    case Type::int64:
      w.i64(*v.asInt64());
      return;
    case Type::uint64:
      w.u64(*v.asUint64());
      return;
    case Type::float64:
      w.f64(*v.asDouble());
      return;
    case Type::string:
      w.str32(*v.asString());
      return;
    case Type::bytes:
      w.str32(v.asBytes()->data);
      return;
    case Type::list:
      w.u32(static_cast<uint32_t>(v.asList()->size()));
      for (const Variant& item : *v.asList()) encodeTo(item, w);
      return;
    case Type::map:
      w.u32(static_cast<uint32_t>(v.asMap()->size()));
      for (const auto& [key, item] : *v.asMap()) {
        w.str16(key);
        encodeTo(item, w);
      }
      return;
  }
}

// Walks a value for checkEncodable(); `path` names the place in JSON-path style.
Result<void> checkValue(const Variant& v, size_t depth, size_t max_depth, std::string& path) {
  const auto problem = [&](Errc code, const std::string& why) {
    return makeError(code, (path.empty() ? "$" : path) + ": " + why);
  };
  if (depth > max_depth) {
    return problem(Errc::limit_exceeded, "nesting depth " + std::to_string(depth) +
                                             " exceeds the limit of " + std::to_string(max_depth));
  }
  constexpr size_t kU32 = std::numeric_limits<uint32_t>::max();
  switch (v.type()) {
    case Type::string:
      if (v.asString()->size() > kU32) return problem(Errc::limit_exceeded, "string too long");
      if (!isValidUtf8(*v.asString())) {
        return problem(Errc::invalid_argument, "string is not valid UTF-8");
      }
      return {};
    case Type::bytes:
      if (v.asBytes()->data.size() > kU32) return problem(Errc::limit_exceeded, "bytes too long");
      return {};
    case Type::list: {
      if (v.asList()->size() > kU32) return problem(Errc::limit_exceeded, "list too long");
      const std::string base = path.empty() ? "$" : path;
      size_t i = 0;
      for (const Variant& item : *v.asList()) {
        path = base + "[" + std::to_string(i++) + "]";
        Result<void> r = checkValue(item, depth + 1, max_depth, path);
        if (!r) return r;
      }
      path = base;
      return {};
    }
    case Type::map: {
      if (v.asMap()->size() > kU32) return problem(Errc::limit_exceeded, "map too large");
      const std::string base = path.empty() ? "$" : path;
      for (const auto& [key, item] : *v.asMap()) {
        if (key.size() > std::numeric_limits<uint16_t>::max()) {
          return problem(Errc::limit_exceeded,
                         "key of " + std::to_string(key.size()) + " bytes exceeds 65535");
        }
        if (!isValidUtf8(key)) return problem(Errc::invalid_argument, "key is not valid UTF-8");
        path = base + "." + quoteKey(key);
        Result<void> r = checkValue(item, depth + 1, max_depth, path);
        if (!r) return r;
      }
      path = base;
      return {};
    }
    default:
      return {};
  }
}

}  // namespace

void encodeVariant(const Variant& v, ByteWriter& out) {
  encodeTo(v, out);
}

size_t encodedSize(const Variant& v) noexcept {
  switch (v.type()) {
    case Type::null:
      return 1;
    case Type::boolean:
      return 2;
    case Type::int64:
    case Type::uint64:
    case Type::float64:
      return 9;
    case Type::string:
      return 5 + v.asString()->size();
    case Type::bytes:
      return 5 + v.asBytes()->data.size();
    case Type::list: {
      size_t n = 5;
      for (const Variant& item : *v.asList()) n += encodedSize(item);
      return n;
    }
    case Type::map: {
      size_t n = 5;
      for (const auto& [key, item] : *v.asMap()) n += 2 + key.size() + encodedSize(item);
      return n;
    }
  }
  return 0;
}

Result<void> checkEncodable(const Variant& v, const DecodeLimits& limits) {
  std::string path;
  Result<void> r = checkValue(v, 1, limits.max_depth, path);
  if (!r) return r;
  const size_t size = encodedSize(v);
  if (size > limits.max_bytes) {
    return makeError(Errc::limit_exceeded, "$: encoded size " + std::to_string(size) +
                                               " exceeds the limit of " +
                                               std::to_string(limits.max_bytes));
  }
  return {};
}

Result<Variant> decodeVariant(ByteReader& in, const DecodeLimits& limits) {
  const bool capped = in.remaining() > limits.max_bytes;
  Decoder d(ByteReader(in.position(), capped ? limits.max_bytes : in.remaining()), limits.max_depth,
            capped, limits.max_bytes);
  Result<Variant> v = d.value(1);
  if (v) {
    std::string_view skipped;
    in.view(d.consumed(), skipped);
  }
  return v;
}

}  // namespace skr::flow
