// SPDX-License-Identifier: Apache-2.0
// A small declarative schema for JSON values (jsoncpp), so that a config section reads as a few
// lines and every problem in a document is reported at once, with its path:
//
//   namespace s = skr::schema;
//   s::Schema server = s::object({
//       s::required("port", s::integer().range(1, 65535)),
//       s::optional("bind", s::string().nonEmpty(), "127.0.0.1"),
//   });
//   for (const s::Problem& p : s::validate(doc["server"], server, "$.server")) ...
//
// Pure functions of their arguments; thread-safe; no exceptions escape.
#pragma once

#include <json/value.h>

#include <cstddef>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace skr::schema {

// One thing wrong in a document.
struct Problem {
  std::string path;    // "$", "$.loop.fast_tick_ms", "$.modules[2].enabled"
  std::string reason;  // "expected boolean, got string", "must be >= 1, got 0", ...
};
using Problems = std::vector<Problem>;

enum class Kind { object, array, string, integer, number, boolean, any_object, any };

struct Field;
struct Schema;

// An extra rule, run once the value passed everything else its schema says (type, range,
// fields, elements). It sees the value with defaults filled in, and appends to `out`.
using Check = std::function<void(const Json::Value& value, const std::string& path, Problems& out)>;

// What a value must look like. Build one with the functions below, then refine it with the
// chained modifiers, each of which returns a modified copy.
struct Schema {
  Kind kind = Kind::any_object;
  std::vector<Field> fields;              // object: the keys it knows
  bool unknown_keys_allowed = false;      // object: extra keys are an error by default
  std::shared_ptr<const Schema> element;  // array: every element
  std::size_t min_items = 0;              // array
  std::size_t max_items = std::numeric_limits<std::size_t>::max();
  std::vector<std::string> allowed;  // string: allowed values; empty means any
  bool non_empty = false;            // string
  std::optional<double> min;         // integer, number: inclusive bounds
  std::optional<double> max;
  std::vector<Check> checks;

  [[nodiscard]] Schema oneOf(std::vector<std::string> values) const;
  [[nodiscard]] Schema nonEmpty() const;
  [[nodiscard]] Schema range(double lo, double hi) const;
  [[nodiscard]] Schema atLeast(double lo) const;
  [[nodiscard]] Schema atMost(double hi) const;
  [[nodiscard]] Schema items(std::size_t lo, std::size_t hi) const;
  [[nodiscard]] Schema allowUnknownKeys() const;
  [[nodiscard]] Schema check(Check rule) const;
};

// A named member of an object.
struct Field {
  std::string key;
  Schema schema;
  bool required = false;
  Json::Value default_value;  // filled in by withDefaults() when missing; null means none
};

[[nodiscard]] Schema object(std::vector<Field> fields);
[[nodiscard]] Schema arrayOf(Schema element);
[[nodiscard]] Schema string();
[[nodiscard]] Schema integer();  // an integral number (10 and 10.0 both pass)
[[nodiscard]] Schema number();
[[nodiscard]] Schema boolean();
[[nodiscard]] Schema anyObject();  // any JSON object, its contents unchecked
[[nodiscard]] Schema any();        // any JSON value except null, unchecked

[[nodiscard]] Field required(std::string key, Schema schema);
// `default_value` may be a scalar, or Json::objectValue for a section whose own fields have
// defaults; leave it null for a key that stays absent when missing.
[[nodiscard]] Field optional(std::string key, Schema schema, Json::Value default_value = {});

// Every problem in `value`, in a stable order; empty when it conforms. `path` names `value`.
[[nodiscard]] Problems validate(const Json::Value& value, const Schema& schema,
                                const std::string& path = "$");

// A copy of `value` with every missing optional key that has a default filled in, recursively
// (also inside array elements). Parts of the wrong type are copied unchanged.
[[nodiscard]] Json::Value withDefaults(const Json::Value& value, const Schema& schema);

// Path helpers: childPath("$.a", "b") is "$.a.b" (or `$.a["b c"]` for keys that are not
// identifiers); indexPath("$.a", 2) is "$.a[2]".
[[nodiscard]] std::string childPath(const std::string& path, std::string_view key);
[[nodiscard]] std::string indexPath(const std::string& path, std::size_t index);

// A number as a person writes it: 0.1, 10, 1e+20.
[[nodiscard]] std::string formatNumber(double value);

// One line per problem: "<origin>: <path>: <reason>", lines joined by '\n'.
[[nodiscard]] std::string formatProblems(const Problems& problems, std::string_view origin);

}  // namespace skr::schema
