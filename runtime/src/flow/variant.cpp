// SPDX-License-Identifier: Apache-2.0
// Variant accessors, equality, UTF-8 validation and base64 (skrobot/base64.hpp). The binary codec
// is in variant_binary.cpp, the JSON mapping in variant_json.cpp.
#include <skrobot/runtime/flow/variant.h>
#include <skrobot/base64.hpp>

#include <cmath>
#include <cstring>
#include <limits>

namespace skr::flow {

std::string_view Variant::typeName(Type type) noexcept {
  switch (type) {
    case Type::null:
      return "null";
    case Type::boolean:
      return "bool";
    case Type::int64:
      return "int64";
    case Type::uint64:
      return "uint64";
    case Type::float64:
      return "float64";
    case Type::string:
      return "string";
    case Type::bytes:
      return "bytes";
    case Type::list:
      return "list";
    case Type::map:
      return "map";
  }
  return "unknown";
}

std::optional<bool> Variant::asBool() const noexcept {
  if (const bool* b = std::get_if<bool>(&v_)) return *b;
  return std::nullopt;
}

namespace {
// 2^63 and 2^64 are exact doubles; an integral double d fits int64 iff -2^63 <= d < 2^63.
constexpr double kTwo63 = 9223372036854775808.0;
constexpr double kTwo64 = 18446744073709551616.0;
}  // namespace

std::optional<int64_t> Variant::asInt64() const noexcept {
  switch (type()) {
    case Type::int64:
      return *std::get_if<int64_t>(&v_);
    case Type::uint64: {
      const uint64_t u = *std::get_if<uint64_t>(&v_);
      if (u <= static_cast<uint64_t>(std::numeric_limits<int64_t>::max())) {
        return static_cast<int64_t>(u);
      }
      return std::nullopt;
    }
    case Type::float64: {
      const double d = *std::get_if<double>(&v_);
      if (std::trunc(d) == d && d >= -kTwo63 && d < kTwo63) return static_cast<int64_t>(d);
      return std::nullopt;
    }
    default:
      return std::nullopt;
  }
}

std::optional<uint64_t> Variant::asUint64() const noexcept {
  switch (type()) {
    case Type::uint64:
      return *std::get_if<uint64_t>(&v_);
    case Type::int64: {
      const int64_t i = *std::get_if<int64_t>(&v_);
      if (i >= 0) return static_cast<uint64_t>(i);
      return std::nullopt;
    }
    case Type::float64: {
      const double d = *std::get_if<double>(&v_);
      if (std::trunc(d) == d && d >= 0 && d < kTwo64) return static_cast<uint64_t>(d);
      return std::nullopt;
    }
    default:
      return std::nullopt;
  }
}

std::optional<double> Variant::asDouble() const noexcept {
  switch (type()) {
    case Type::float64:
      return *std::get_if<double>(&v_);
    case Type::int64:
      return static_cast<double>(*std::get_if<int64_t>(&v_));
    case Type::uint64:
      return static_cast<double>(*std::get_if<uint64_t>(&v_));
    default:
      return std::nullopt;
  }
}

const std::string* Variant::asString() const noexcept {
  return std::get_if<std::string>(&v_);
}
const Variant::Bytes* Variant::asBytes() const noexcept {
  return std::get_if<Bytes>(&v_);
}

const Variant::List* Variant::asList() const noexcept {
  const auto* b = std::get_if<detail::Boxed<List>>(&v_);
  return b ? &b->get() : nullptr;
}
Variant::List* Variant::asList() noexcept {
  auto* b = std::get_if<detail::Boxed<List>>(&v_);
  return b ? &b->get() : nullptr;
}
const Variant::Map* Variant::asMap() const noexcept {
  const auto* b = std::get_if<detail::Boxed<Map>>(&v_);
  return b ? &b->get() : nullptr;
}
Variant::Map* Variant::asMap() noexcept {
  auto* b = std::get_if<detail::Boxed<Map>>(&v_);
  return b ? &b->get() : nullptr;
}

const Variant* Variant::find(std::string_view key) const noexcept {
  const Map* m = asMap();
  if (m == nullptr) return nullptr;
  const auto it = m->find(key);
  return it == m->end() ? nullptr : &it->second;
}

bool operator==(const Variant& a, const Variant& b) noexcept {
  if (a.type() != b.type()) return false;
  switch (a.type()) {
    case Variant::Type::null:
      return true;
    case Variant::Type::boolean:
      return *a.asBool() == *b.asBool();
    case Variant::Type::int64:
      return *std::get_if<int64_t>(&a.v_) == *std::get_if<int64_t>(&b.v_);
    case Variant::Type::uint64:
      return *std::get_if<uint64_t>(&a.v_) == *std::get_if<uint64_t>(&b.v_);
    case Variant::Type::float64: {
      const double x = *std::get_if<double>(&a.v_);
      const double y = *std::get_if<double>(&b.v_);
      return x == y || (std::isnan(x) && std::isnan(y));
    }
    case Variant::Type::string:
      return *a.asString() == *b.asString();
    case Variant::Type::bytes:
      return *a.asBytes() == *b.asBytes();
    case Variant::Type::list:
      return *a.asList() == *b.asList();
    case Variant::Type::map:
      return *a.asMap() == *b.asMap();
  }
  return false;
}

bool isValidUtf8(std::string_view s) noexcept {
  const auto* p = reinterpret_cast<const unsigned char*>(s.data());
  const auto* end = p + s.size();
  while (p < end) {
    uint64_t eight = 0;  // ASCII runs eight bytes at a time
    if (end - p >= 8 && (std::memcpy(&eight, p, 8), (eight & 0x8080808080808080u) == 0)) {
      p += 8;
      continue;
    }
    const unsigned c = *p;
    if (c < 0x80) {
      ++p;
      continue;
    }
    size_t n = 0;
    uint32_t cp = 0;
    uint32_t min = 0;
    if (c >= 0xC2 && c <= 0xDF) {
      n = 1, cp = c & 0x1F, min = 0x80;
    } else if (c >= 0xE0 && c <= 0xEF) {
      n = 2, cp = c & 0x0F, min = 0x800;
    } else if (c >= 0xF0 && c <= 0xF4) {
      n = 3, cp = c & 0x07, min = 0x10000;
    } else {
      return false;  // continuation byte, overlong lead (C0, C1) or beyond U+10FFFF (F5..FF)
    }
    if (static_cast<size_t>(end - p) <= n) return false;
    for (size_t i = 1; i <= n; ++i) {
      if ((p[i] & 0xC0) != 0x80) return false;
      cp = (cp << 6) | (p[i] & 0x3F);
    }
    if (cp < min || cp > 0x10FFFF || (cp >= 0xD800 && cp <= 0xDFFF)) return false;
    p += n + 1;
  }
  return true;
}

std::string base64Encode(std::string_view bytes) {
  return base64::encode(bytes);
}

std::optional<std::string> base64Decode(std::string_view text) {
  return base64::decode(text);
}

}  // namespace skr::flow
