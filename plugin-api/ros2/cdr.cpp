// SPDX-License-Identifier: Apache-2.0
#include <skrobot/ros2/cdr.h>

#include "cdr_stream.h"

#include <algorithm>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <type_traits>
#include <utility>
#include <vector>

namespace skr::ros2 {
namespace {

std::size_t sizeOf(Primitive p) {
  switch (p) {
    case Primitive::boolean:
    case Primitive::byte:
    case Primitive::character:
    case Primitive::int8:
    case Primitive::uint8:
      return 1;
    case Primitive::int16:
    case Primitive::uint16:
      return 2;
    case Primitive::int32:
    case Primitive::uint32:
    case Primitive::float32:
      return 4;
    case Primitive::int64:
    case Primitive::uint64:
    case Primitive::float64:
      return 8;
    case Primitive::string:
    case Primitive::wstring:
      return 4;  // the length in front
  }
  return 1;
}

// A float32 as the double its shortest decimal form reads as: 0.1f is 0.1 in JSON, not
// 0.10000000149011612, and the double goes back to the same float.
double shortestAsDouble(float v) {
  char text[32];
  const auto written = std::to_chars(text, text + sizeof text, v);
  double d = static_cast<double>(v);
  if (written.ec == std::errc()) (void)std::from_chars(text, written.ptr, d);
  return d;
}

// --- reading ---------------------------------------------------------------------------------

struct Decoder {
  const Registry& registry;
  CdrIn in;
  std::string path;  // the field being read, without the index of the array element
  std::string why;
  bool build = true;  // false: only check (validate), no JSON built
  // The array elements being read, innermost last: the path of an error names them.
  std::vector<std::pair<std::size_t, std::uint32_t>> indices;  // (path length, index)

  bool fail(const std::string& what) {
    std::string at = path;
    for (auto it = indices.rbegin(); it != indices.rend(); ++it) {
      at.insert(it->first, "[" + std::to_string(it->second) + "]");
    }
    why = at + ": " + what + " at byte " + std::to_string(in.at());
    return false;
  }

  template <typename T>
  bool number(Json::Value& out) {
    T v{};
    if (!in.read(v)) return fail("the sample ends");
    if constexpr (std::is_floating_point_v<T>) {
      if (!std::isfinite(v)) {
        out = Json::Value();
      } else if constexpr (std::is_same_v<T, float>) {
        out = Json::Value(shortestAsDouble(v));
      } else {
        out = Json::Value(static_cast<double>(v));
      }
    } else if constexpr (std::is_signed_v<T>) {
      out = Json::Value(static_cast<Json::Int64>(v));
    } else {
      out = Json::Value(static_cast<Json::UInt64>(v));
    }
    return true;
  }

  bool primitive(Primitive p, std::uint32_t bound, Json::Value& out) {
    switch (p) {
      case Primitive::boolean: {
        std::uint8_t b = 0;
        if (!in.read(b)) return fail("the sample ends");
        if (b > 1) return fail("a bool of " + std::to_string(b));
        out = Json::Value(b == 1);
        return true;
      }
      case Primitive::byte:
      case Primitive::character:
      case Primitive::uint8:
        return number<std::uint8_t>(out);
      case Primitive::int8:
        return number<std::int8_t>(out);
      case Primitive::int16:
        return number<std::int16_t>(out);
      case Primitive::uint16:
        return number<std::uint16_t>(out);
      case Primitive::int32:
        return number<std::int32_t>(out);
      case Primitive::uint32:
        return number<std::uint32_t>(out);
      case Primitive::int64:
        return number<std::int64_t>(out);
      case Primitive::uint64:
        return number<std::uint64_t>(out);
      case Primitive::float32:
        return number<float>(out);
      case Primitive::float64:
        return number<double>(out);
      case Primitive::string: {
        std::uint32_t n = 0;
        if (!in.read(n)) return fail("the sample ends");
        if (n > in.left()) return fail("a string of " + std::to_string(n) + " bytes");
        std::string_view s;
        (void)in.bytes(n, s);
        if (n > 0) {
          if (s.back() != '\0') return fail("a string without its terminating NUL");
          s.remove_suffix(1);
        }
        if (s.find('\0') != std::string_view::npos) return fail("a string with a NUL inside");
        if (bound != 0 && s.size() > bound) {
          return fail("a string of " + std::to_string(s.size()) + " bytes, over its bound " +
                      std::to_string(bound));
        }
        out = Json::Value(std::string(s));
        return true;
      }
      case Primitive::wstring:
        return fail("wstring is not supported");
    }
    return fail("an unknown type");
  }

  bool element(const FieldType& t, Json::Value& out, int depth) {
    if (t.primitive) return primitive(*t.primitive, t.string_bound, out);
    return message(t.message, out, depth + 1);
  }

  bool field(const Field& f, Json::Value& out, int depth) {
    const FieldType& t = f.type;
    if (t.array == FieldType::Array::none) return element(t, out, depth);
    std::uint32_t count = t.array_size;
    if (t.array != FieldType::Array::fixed) {
      if (!in.read(count)) return fail("the sample ends");
      if (t.array == FieldType::Array::bounded && count > t.array_size) {
        return fail(std::to_string(count) + " elements, over its bound " +
                    std::to_string(t.array_size));
      }
    }
    // Every element takes at least a byte (a message at least one): refused before allocating.
    const std::size_t least = t.primitive ? sizeOf(*t.primitive) : 1;
    if (count > in.left() / least) {
      return fail(std::to_string(count) + " elements, more than the sample holds");
    }
    if (!build && t.primitive && least == 1 && *t.primitive != Primitive::boolean) {
      return in.skip(count) || fail("the sample ends");  // bytes: nothing to check in them
    }
    if (build) out = Json::Value(Json::arrayValue);
    indices.emplace_back(path.size(), 0);
    for (std::uint32_t i = 0; i < count; ++i) {
      indices.back().second = i;
      Json::Value v;
      if (!element(t, v, depth)) return false;
      if (build) out.append(std::move(v));
    }
    indices.pop_back();
    return true;
  }

  bool message(const std::string& name, Json::Value& out, int depth) {
    if (depth > kMaxDepth) return fail("messages nested deeper than " + std::to_string(kMaxDepth));
    const MessageDefinition* def = registry.find(name);
    if (def == nullptr) return fail("no definition of " + name);
    if (build) out = Json::Value(Json::objectValue);
    if (def->fields.empty()) {
      std::uint8_t dummy = 0;  // structure_needs_at_least_one_member
      if (!in.read(dummy)) return fail("the sample ends");
      return true;
    }
    const std::size_t base = path.size();
    Json::Value unused;
    for (const Field& f : def->fields) {
      path.append(".").append(f.name);
      if (!field(f, build ? out[f.name] : unused, depth)) return false;
      path.resize(base);
    }
    return true;
  }
};

// --- writing ---------------------------------------------------------------------------------

const Json::Value kNull;

struct Encoder {
  const Registry& registry;
  CdrOut out;
  std::string path;  // as the decoder's
  std::string why;
  std::vector<std::pair<std::size_t, std::uint32_t>> indices;

  bool fail(const std::string& what) {
    std::string at = path;
    for (auto it = indices.rbegin(); it != indices.rend(); ++it) {
      at.insert(it->first, "[" + std::to_string(it->second) + "]");
    }
    why = at + ": " + what;
    return false;
  }
  template <typename T>
  void put(T v) {
    out.put(v);
  }

  template <typename T>
  bool integer(const Json::Value& v) {
    if (v.isNull()) {
      put(T{});
      return true;
    }
    if (!v.isIntegral() && !(v.isDouble() && std::trunc(v.asDouble()) == v.asDouble())) {
      return fail("not an integer");
    }
    if constexpr (std::is_signed_v<T>) {
      if (!v.isInt64() || v.asInt64() < std::numeric_limits<T>::min() ||
          v.asInt64() > std::numeric_limits<T>::max()) {
        return fail("out of range");
      }
      put(static_cast<T>(v.asInt64()));
    } else {
      if (!v.isUInt64() || v.asUInt64() > std::numeric_limits<T>::max()) {
        return fail("out of range");
      }
      put(static_cast<T>(v.asUInt64()));
    }
    return true;
  }

  bool primitive(Primitive p, std::uint32_t bound, const Json::Value& v) {
    switch (p) {
      case Primitive::boolean:
        if (!v.isNull() && !v.isBool()) return fail("not a boolean");
        put(static_cast<std::uint8_t>(v.isBool() && v.asBool() ? 1 : 0));
        return true;
      case Primitive::byte:
      case Primitive::character:
      case Primitive::uint8:
        return integer<std::uint8_t>(v);
      case Primitive::int8:
        return integer<std::int8_t>(v);
      case Primitive::int16:
        return integer<std::int16_t>(v);
      case Primitive::uint16:
        return integer<std::uint16_t>(v);
      case Primitive::int32:
        return integer<std::int32_t>(v);
      case Primitive::uint32:
        return integer<std::uint32_t>(v);
      case Primitive::int64:
        return integer<std::int64_t>(v);
      case Primitive::uint64:
        return integer<std::uint64_t>(v);
      case Primitive::float32:
        if (!v.isNull() && !v.isNumeric()) return fail("not a number");
        put(static_cast<float>(v.isNull() ? 0.0 : v.asDouble()));
        return true;
      case Primitive::float64:
        if (!v.isNull() && !v.isNumeric()) return fail("not a number");
        put(v.isNull() ? 0.0 : v.asDouble());
        return true;
      case Primitive::string: {
        if (!v.isNull() && !v.isString()) return fail("not a string");
        const std::string s = v.isString() ? v.asString() : std::string();
        if (s.find('\0') != std::string::npos) return fail("a string with a NUL in it");
        if (bound != 0 && s.size() > bound) {
          return fail("a string of " + std::to_string(s.size()) + " bytes, over its bound " +
                      std::to_string(bound));
        }
        put(static_cast<std::uint32_t>(s.size() + 1));
        out.append(std::string_view(s.c_str(), s.size() + 1));  // its NUL too
        return true;
      }
      case Primitive::wstring:
        return fail("wstring is not supported");
    }
    return fail("an unknown type");
  }

  bool element(const FieldType& t, const Json::Value& v, int depth) {
    if (t.primitive) return primitive(*t.primitive, t.string_bound, v);
    return message(t.message, v, depth + 1);
  }

  bool field(const Field& f, const Json::Value& given, int depth) {
    const Json::Value& v = given.isNull() && f.default_value ? *f.default_value : given;
    const FieldType& t = f.type;
    if (t.array == FieldType::Array::none) return element(t, v, depth);
    if (!v.isNull() && !v.isArray()) return fail("not an array");
    const Json::ArrayIndex n = v.isArray() ? v.size() : 0;
    if (t.array == FieldType::Array::fixed) {
      if (n != t.array_size && !(n == 0 && v.isNull())) {
        return fail(std::to_string(n) + " elements where it takes " + std::to_string(t.array_size));
      }
    } else {
      if (t.array == FieldType::Array::bounded && n > t.array_size) {
        return fail(std::to_string(n) + " elements, over its bound " +
                    std::to_string(t.array_size));
      }
      put(static_cast<std::uint32_t>(n));
    }
    const std::uint32_t count = t.array == FieldType::Array::fixed ? t.array_size : n;
    indices.emplace_back(path.size(), 0);
    for (std::uint32_t i = 0; i < count; ++i) {
      indices.back().second = i;
      if (!element(t, i < n ? v[i] : kNull, depth)) return false;
    }
    indices.pop_back();
    return true;
  }

  bool message(const std::string& name, const Json::Value& v, int depth) {
    if (depth > kMaxDepth) return fail("messages nested deeper than " + std::to_string(kMaxDepth));
    const MessageDefinition* def = registry.find(name);
    if (def == nullptr) return fail("no definition of " + name);
    if (!v.isNull() && !v.isObject()) return fail("not an object (a " + name + ")");
    if (v.isObject()) {
      for (const auto& key : v.getMemberNames()) {
        const bool known = std::any_of(def->fields.begin(), def->fields.end(),
                                       [&](const Field& f) { return f.name == key; });
        if (!known) {
          path += "." + key;
          return fail("no such field in " + name);
        }
      }
    }
    if (def->fields.empty()) {
      put(std::uint8_t{0});  // structure_needs_at_least_one_member
      return true;
    }
    const std::size_t base = path.size();
    for (const Field& f : def->fields) {
      path.append(".").append(f.name);
      const Json::Value* given =
          v.isObject() ? v.find(f.name.data(), f.name.data() + f.name.size()) : nullptr;
      if (!field(f, given != nullptr ? *given : kNull, depth)) return false;
      path.resize(base);
    }
    return true;
  }
};

}  // namespace

namespace {

// Reads a whole sample: its header, its fields, and at most 3 bytes of padding after them.
Result<Json::Value> decode(const Registry& registry, std::string_view type, std::string_view bytes,
                           bool build) {
  const MessageDefinition* def = registry.find(type);
  if (def == nullptr) return makeError(Errc::not_found, "no definition of " + std::string(type));
  if (bytes.size() < kEncapsulationBytes || bytes[0] != 0 || (bytes[1] != 0 && bytes[1] != 1)) {
    return makeError(Errc::parse_error,
                     std::string(type) + ": not a CDR sample (its encapsulation header)");
  }
  Decoder d{registry, CdrIn(bytes, bytes[1] == 1), def->name, {}, build, {}};
  Json::Value out;
  if (!d.message(def->name, out, 0)) return makeError(Errc::parse_error, d.why);
  if (d.in.left() > 3) {
    return makeError(Errc::parse_error, def->name + ": " + std::to_string(d.in.left()) +
                                            " bytes after the last field (another type?)");
  }
  return out;
}

}  // namespace

Result<Json::Value> cdrToJson(const Registry& registry, std::string_view type,
                              std::string_view bytes) {
  return decode(registry, type, bytes, true);
}

Result<void> validate(const Registry& registry, std::string_view type, std::string_view bytes) {
  if (auto r = decode(registry, type, bytes, false); !r) return r.error();
  return {};
}

Result<std::string> jsonToCdr(const Registry& registry, std::string_view type,
                              const Json::Value& value) {
  const MessageDefinition* def = registry.find(type);
  if (def == nullptr) return makeError(Errc::not_found, "no definition of " + std::string(type));
  Encoder e{registry, CdrOut(), def->name, {}, {}};
  if (!e.message(def->name, value, 0)) return makeError(Errc::invalid_argument, e.why);
  return e.out.take();
}

}  // namespace skr::ros2
