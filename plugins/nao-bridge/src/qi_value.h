// SPDX-License-Identifier: Apache-2.0
// A qi value (what a signature describes) and its binary serialization, little-endian:
// integers and floats as is, bool 1 byte, string/raw a uint32 length then bytes, list/map a uint32
// count then elements, tuple its members, dynamic 'm' a signature string then the value.
#pragma once

#include "qi_signature.h"

#include <cstdint>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace skr::nao::qi {

class Value {
 public:
  enum class Kind { none, boolean, integer, real, string, list, map, tuple };

  Value() = default;
  static Value boolean(bool b);
  static Value integer(std::int64_t i, char sig = 'i');  // sig: c C w W i I l L
  static Value real(double d, char sig = 'f');           // sig: f d
  static Value string(std::string s, char sig = 's');    // sig: s r
  static Value list(std::vector<Value> items);
  static Value map(std::vector<std::pair<Value, Value>> entries);
  static Value tuple(std::vector<Value> items, std::string name = {},
                     std::vector<std::string> fields = {});
  static Value strings(const std::vector<std::string>& v);
  static Value reals(const std::vector<double>& v);

  [[nodiscard]] Kind kind() const noexcept { return kind_; }
  [[nodiscard]] char sig() const noexcept { return sig_; }
  [[nodiscard]] bool isNumber() const noexcept {
    return kind_ == Kind::integer || kind_ == Kind::real || kind_ == Kind::boolean;
  }
  [[nodiscard]] bool asBool() const noexcept { return b_; }
  [[nodiscard]] std::int64_t asInt() const noexcept { return i_; }
  // Any number as a double (bool as 0/1).
  [[nodiscard]] double asDouble() const noexcept;
  [[nodiscard]] const std::string& asString() const noexcept { return s_; }
  [[nodiscard]] const std::vector<Value>& items() const noexcept { return items_; }
  [[nodiscard]] const std::vector<std::pair<Value, Value>>& entries() const noexcept {
    return entries_;
  }
  // Map entry by string key, or nullptr.
  [[nodiscard]] const Value* find(std::string_view key) const;
  // The signature a dynamic ('m') value of this content is sent with.
  [[nodiscard]] Type naturalType() const;
  // Debug text, JSON-like.
  [[nodiscard]] std::string text() const;

  bool operator==(const Value& o) const;

 private:
  Kind kind_ = Kind::none;
  char sig_ = 'v';
  bool b_ = false;
  std::int64_t i_ = 0;
  double d_ = 0;
  std::string s_;
  std::vector<Value> items_;
  std::vector<std::pair<Value, Value>> entries_;
  std::string name_;
  std::vector<std::string> fields_;
};

// Reads values of a known type from a byte buffer. Counts are checked against the bytes left
// before anything is allocated; dynamic values nest at most kMaxValueDepth deep, and a payload
// yields at most kMaxDecodedValues values. Without `used`, the value must fill `bytes` exactly
// (bytes left over are an error); with it, *used receives how many bytes the value took.
constexpr int kMaxValueDepth = 32;
constexpr std::size_t kMaxDecodedValues = 1u << 18;  // per payload; bounds memory to ~50 MiB

[[nodiscard]] Result<Value> decode(const Type& t, std::string_view bytes,
                                   std::size_t* used = nullptr);
[[nodiscard]] Result<Value> decode(std::string_view sig, std::string_view bytes,
                                   std::size_t* used = nullptr);
// Appends `v` serialized as `t`, converting numbers where no precision class is lost in kind
// (integer -> real, any integer width with a range check); 'm' sends v with its natural type.
[[nodiscard]] Result<void> encode(const Type& t, const Value& v, std::string& out);
[[nodiscard]] Result<std::string> encode(std::string_view sig, const Value& v);

}  // namespace skr::nao::qi
