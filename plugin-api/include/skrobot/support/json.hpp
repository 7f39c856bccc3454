// SPDX-License-Identifier: Apache-2.0
// JSON in and out for modules: one parser, one writer, one string quoter (the module-support
// library, skrobot::module_support, linked by every module through skrobot_add_module).
//
// Values are jsoncpp's Json::Value. Nothing here throws: parse errors come back as a Result, and
// jsoncpp's own exceptions (it throws past its recursion limit) are caught inside.
//
// Output rules, the same for writeJson and jsonQuote:
// - compact, one line, no trailing newline; object members in jsoncpp's order (sorted by key);
// - strings: '"', '\\' and every control character below U+0020 are escaped (\n \r \t \b \f,
//   others as \u00XX), as is U+007F; valid UTF-8 is written as UTF-8 (not as \u escapes); a byte
//   that does not start a valid UTF-8 sequence (overlong, surrogate, > U+10FFFF, truncated)
//   becomes U+FFFD, so the output is always valid UTF-8 and valid JSON;
// - integers exactly; doubles in the shortest form that reads back to the same double
//   (std::to_chars), with ".0" added to integral values so they stay doubles when read back;
//   NaN and infinities become null (JSON has no spelling for them).
#pragma once

#include <skrobot/result.hpp>

#include <json/value.h>

#include <cstddef>
#include <string>
#include <string_view>

namespace skr::support {

struct JsonLimits {
  // Deepest nesting of arrays and objects accepted; a scalar root is depth 0, "[]" depth 1.
  std::size_t max_depth = 64;
  // Longest text accepted, in bytes.
  std::size_t max_bytes = 4u << 20;
};

// Parses one JSON value (any type at the root) in strict mode: no comments, no trailing commas,
// no single quotes, no NaN/Infinity, no duplicate keys, no raw control characters (escape them
// in strings), nothing but whitespace after the value. Strings are not checked for UTF-8:
// writeJson replaces what is not.
// Errors: Errc::limit_exceeded for text larger than max_bytes or nesting deeper than max_depth;
// Errc::parse_error otherwise, with a one-line message naming the line and column.
[[nodiscard]] Result<Json::Value> parseJson(std::string_view text, JsonLimits limits = {});

// Like parseJson, but the root must be an object (Errc::parse_error otherwise).
[[nodiscard]] Result<Json::Value> parseJsonObject(std::string_view text, JsonLimits limits = {});

// The value as compact JSON text (see the output rules above). Never throws.
[[nodiscard]] std::string writeJson(const Json::Value& value);

// `text` as a JSON string literal, quotes included (see the output rules above), for small
// hand-built messages: "{\"error\":" + jsonQuote(message) + "}".
[[nodiscard]] std::string jsonQuote(std::string_view text);

// Bytes as the JSON mapping of values spells them (docs/pair-databases.md): {"$base64": "..."},
// standard base64 with padding; the hub hands them on as a bytes value (a service's audio, say).
[[nodiscard]] Json::Value jsonBytes(std::string_view bytes);

// A Json::Value type as a word for error messages: "null", "integer", "number", "string",
// "boolean", "array", "object".
[[nodiscard]] std::string_view jsonTypeName(const Json::Value& value) noexcept;

}  // namespace skr::support
