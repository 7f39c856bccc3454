// SPDX-License-Identifier: Apache-2.0
// Variant: the typed value of PairDatabases and FlowProtocol payloads (null, bool, int64, uint64,
// float64, UTF-8 string, bytes, list, map), with its binary wire encoding and its JSON mapping.
// docs/flow-protocol.md specifies the binary encoding byte by byte; docs/pair-databases.md the
// JSON mapping. A Variant is a plain value: copies are deep, moves are cheap and leave null.
#pragma once

#include <skrobot/runtime/flow/bytes.h>
#include <skrobot/runtime/result.h>

#include <json/value.h>

#include <concepts>
#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <type_traits>
#include <variant>
#include <vector>

namespace skr::flow {

// Bounds for reading a Variant that came off a socket (or out of a file).
struct DecodeLimits {
  size_t max_depth = 32;  // nesting; the outermost value is at depth 1
  size_t max_bytes =
      size_t{16} * 1024 * 1024;  // encoded size (binary) or text size (JSON) of one value
};

namespace detail {
// A heap-held T with value semantics, so that Variant can hold containers of itself. Never null
// except after a move; Variant resets a moved-from value to null, so users never see that state.
template <class T>
class Boxed {
 public:
  explicit Boxed(T v) : p_(std::make_unique<T>(std::move(v))) {}
  Boxed(const Boxed& o) : p_(std::make_unique<T>(*o.p_)) {}
  Boxed(Boxed&&) noexcept = default;
  Boxed& operator=(const Boxed& o) {
    if (this != &o) p_ = std::make_unique<T>(*o.p_);
    return *this;
  }
  Boxed& operator=(Boxed&&) noexcept = default;
  ~Boxed() = default;
  T& get() noexcept { return *p_; }
  const T& get() const noexcept { return *p_; }

 private:
  std::unique_ptr<T> p_;
};

// Character types are text, not numbers (int8_t and uint8_t are numbers).
template <class T>
concept CharType = std::same_as < std::remove_cv_t<T>,
char > || std::same_as<std::remove_cv_t<T>, wchar_t> ||
    std::same_as<std::remove_cv_t<T>, char8_t> || std::same_as<std::remove_cv_t<T>, char16_t> ||
    std::same_as<std::remove_cv_t<T>, char32_t>;
template <class T>
concept SignedInt = std::signed_integral<T> && !CharType<T>;
template <class T>
concept UnsignedInt = std::unsigned_integral<T> && !std::same_as<T, bool> && !CharType<T>;
}  // namespace detail

class Variant {
 public:
  // The numbers are the binary encoding's tags.
  enum class Type : uint8_t {
    null = 0,
    boolean = 1,
    int64 = 2,
    uint64 = 3,
    float64 = 4,
    string = 5,
    bytes = 6,
    list = 7,
    map = 8,
  };

  // Raw bytes, distinct from text: Variant(Bytes{...}) is bytes, Variant(std::string) is a string.
  struct Bytes {
    std::string data;
    Bytes() = default;
    explicit Bytes(std::string d) : data(std::move(d)) {}
    Bytes(const void* p, size_t n) : data(static_cast<const char*>(p), n) {}
    explicit Bytes(const std::vector<uint8_t>& v) : Bytes(v.data(), v.size()) {}
    bool operator==(const Bytes&) const = default;
  };
  using List = std::vector<Variant>;
  using Map = std::map<std::string, Variant, std::less<>>;  // sorted by key bytes

  Variant() noexcept = default;                            // null
  Variant(std::nullptr_t) noexcept {}                      // NOLINT(google-explicit-constructor)
  Variant(bool b) noexcept : v_(b) {}                      // NOLINT(google-explicit-constructor)
  template <detail::SignedInt T>                           // int, long, int64_t, ... -> int64
  Variant(T i) noexcept : v_(static_cast<int64_t>(i)) {}   // NOLINT(google-explicit-constructor)
  template <detail::UnsignedInt T>                         // unsigned, size_t, uint64_t -> uint64
  Variant(T u) noexcept : v_(static_cast<uint64_t>(u)) {}  // NOLINT(google-explicit-constructor)
  template <std::floating_point T>                         // float, double -> float64
  Variant(T d) noexcept : v_(static_cast<double>(d)) {}    // NOLINT(google-explicit-constructor)
  Variant(const char* s) : v_(std::string(s)) {}           // NOLINT(google-explicit-constructor)
  Variant(std::string s) noexcept : v_(std::move(s)) {}    // NOLINT(google-explicit-constructor)
  Variant(std::string_view s) : v_(std::string(s)) {}      // NOLINT(google-explicit-constructor)
  Variant(Bytes b) noexcept : v_(std::move(b)) {}          // NOLINT(google-explicit-constructor)
  Variant(List l) : v_(detail::Boxed<List>(std::move(l))) {}  // NOLINT(google-explicit-constructor)
  Variant(Map m) : v_(detail::Boxed<Map>(std::move(m))) {}    // NOLINT(google-explicit-constructor)
  // Characters and other pointers would silently become int64 or bool: refused at compile time.
  template <detail::CharType T>
  Variant(T) = delete;
  template <class T>
  requires(!std::same_as<std::remove_cv_t<T>, char>) Variant(T*)
  = delete;

  // Assignment takes a copy (or the value) first, so that `v = (*v.asList())[0]` is safe.
  Variant(const Variant&) = default;
  Variant& operator=(const Variant& o) {
    if (this != &o) *this = Variant(o);
    return *this;
  }
  // Every alternative moves without throwing (clang-tidy cannot see it through std::variant).
  Variant(Variant&& o) noexcept  // NOLINT(bugprone-exception-escape)
      : v_(std::move(o.v_)) {
    o.v_ = std::monostate{};
  }
  Variant& operator=(Variant&& o) noexcept {  // NOLINT(bugprone-exception-escape)
    if (this != &o) {
      Variant taken(std::move(o));  // `o` may live inside *this
      v_ = std::move(taken.v_);
    }
    return *this;
  }
  ~Variant() = default;

  [[nodiscard]] Type type() const noexcept { return static_cast<Type>(v_.index()); }
  // "null", "bool", "int64", "uint64", "float64", "string", "bytes", "list", "map".
  [[nodiscard]] static std::string_view typeName(Type type) noexcept;
  [[nodiscard]] std::string_view typeName() const noexcept { return typeName(type()); }

  [[nodiscard]] bool isNull() const noexcept { return type() == Type::null; }
  [[nodiscard]] bool isBool() const noexcept { return type() == Type::boolean; }
  [[nodiscard]] bool isInt64() const noexcept { return type() == Type::int64; }
  [[nodiscard]] bool isUint64() const noexcept { return type() == Type::uint64; }
  [[nodiscard]] bool isDouble() const noexcept { return type() == Type::float64; }
  [[nodiscard]] bool isNumber() const noexcept { return isInt64() || isUint64() || isDouble(); }
  [[nodiscard]] bool isString() const noexcept { return type() == Type::string; }
  [[nodiscard]] bool isBytes() const noexcept { return type() == Type::bytes; }
  [[nodiscard]] bool isList() const noexcept { return type() == Type::list; }
  [[nodiscard]] bool isMap() const noexcept { return type() == Type::map; }

  // Scalars by value; nullopt when the type does not hold one. Numbers convert when the value
  // fits exactly: asInt64() takes a uint64 <= INT64_MAX or an integral float64 in range; asUint64()
  // a non-negative int64 or integral float64; asDouble() any number (large integers round).
  [[nodiscard]] std::optional<bool> asBool() const noexcept;
  [[nodiscard]] std::optional<int64_t> asInt64() const noexcept;
  [[nodiscard]] std::optional<uint64_t> asUint64() const noexcept;
  [[nodiscard]] std::optional<double> asDouble() const noexcept;
  // Text and containers in place; nullptr when the type differs. The pointer lives as long as the
  // Variant keeps its value.
  [[nodiscard]] const std::string* asString() const noexcept;
  [[nodiscard]] const Bytes* asBytes() const noexcept;
  [[nodiscard]] const List* asList() const noexcept;
  [[nodiscard]] List* asList() noexcept;
  [[nodiscard]] const Map* asMap() const noexcept;
  [[nodiscard]] Map* asMap() noexcept;
  // A map's value at `key`; nullptr when this is not a map or has no such key.
  [[nodiscard]] const Variant* find(std::string_view key) const noexcept;

  // Same type and same value. float64 compares with ==, except that NaN equals NaN, so that a
  // value always equals its copy (and 0.0 equals -0.0). int64 1 and uint64 1 differ.
  friend bool operator==(const Variant& a, const Variant& b) noexcept;

  // JSON mapping: null, bool, numbers, strings, lists and maps map naturally; bytes become
  // {"$base64": "<standard base64>"}. Non-finite float64 (NaN, +-inf) become null. A map whose
  // only key is "$base64" or "$map" is written {"$map": {...}} so that it reads back as a map.
  [[nodiscard]] Json::Value toJson() const;
  // The reverse. A JSON integer gives int64 when it fits, else uint64; a real gives float64. An
  // object with the single key "$base64" must hold valid base64 text and gives bytes; one with the
  // single key "$map" must hold an object, taken as a map as is. Strings and keys must be valid
  // UTF-8 and keys at most 65535 bytes (so that every result can be encoded). Errc::parse_error.
  [[nodiscard]] static Result<Variant> fromJson(const Json::Value& json, size_t max_depth = 32);

 private:
  std::variant<std::monostate, bool, int64_t, uint64_t, double, std::string, Bytes,
               detail::Boxed<List>, detail::Boxed<Map>>
      v_;
};

// Binary encoding (docs/flow-protocol.md): u8 tag (Variant::Type), then
//   bool: u8 0|1; int64, uint64, float64: 8 bytes; string, bytes: u32 length + bytes;
//   list: u32 count + values; map: u32 count + count x (u16 key length + key, value).
// Precondition: checkEncodable(v) holds (strings valid UTF-8, keys <= 65535 bytes, lengths and
// counts <= UINT32_MAX). Every Variant that decodeVariant() or fromJson() produced satisfies it.
void encodeVariant(const Variant& v, ByteWriter& out);
// Bytes that encodeVariant() appends.
[[nodiscard]] size_t encodedSize(const Variant& v) noexcept;
// Whether decodeVariant(limits) would accept encodeVariant(v): UTF-8, key and length limits,
// depth and encoded size. The error (Errc::limit_exceeded or Errc::invalid_argument) names the
// place, e.g. "$.pose[2]: string is not valid UTF-8".
[[nodiscard]] Result<void> checkEncodable(const Variant& v, const DecodeLimits& limits = {});

// Reads one Variant from `in` and advances past it; on error `in` is left where it was. Checks
// every length and count against the bytes left before allocating, never recurses deeper than
// max_depth (one stack frame per level) and fails with Errc::protocol_error naming the reason and
// the byte offset (from the value's first byte), e.g.
//   "string length 4000000 exceeds the 12 bytes left (at byte 1)".
// Memory: a decoded value takes up to ~40 bytes of memory per input byte (a list of nulls).
[[nodiscard]] Result<Variant> decodeVariant(ByteReader& in, const DecodeLimits& limits = {});

// Compact JSON text of toJson(), UTF-8 unescaped.
[[nodiscard]] std::string variantToJsonText(const Variant& v);
// Parses one JSON value (any type at the root; no comments, no trailing text, no duplicate keys)
// and converts it with Variant::fromJson(). Errc::parse_error with the reason.
[[nodiscard]] Result<Variant> variantFromJsonText(std::string_view text,
                                                  const DecodeLimits& limits = {});

// Strict UTF-8: no overlong forms, no surrogates, nothing above U+10FFFF.
[[nodiscard]] bool isValidUtf8(std::string_view s) noexcept;
// Standard base64 (RFC 4648, with padding). decode refuses anything else, including non-zero
// unused bits, so that every byte string has exactly one text.
[[nodiscard]] std::string base64Encode(std::string_view bytes);
[[nodiscard]] std::optional<std::string> base64Decode(std::string_view text);

}  // namespace skr::flow
