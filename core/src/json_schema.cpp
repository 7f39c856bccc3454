// SPDX-License-Identifier: Apache-2.0
#include <skrobot/hub/json_schema.h>
#include <skrobot/support/json.hpp>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <utility>

namespace skr::schema {
namespace {

Schema ofKind(Kind kind) {
  Schema s;
  s.kind = kind;
  return s;
}

std::string quoted(std::string_view text) {
  // Good enough for the keys and values shown in messages; not a JSON encoder.
  return '"' + std::string(text) + '"';
}

std::string_view kindName(Kind kind) noexcept {
  switch (kind) {
    case Kind::object:
    case Kind::any_object:
      return "object";
    case Kind::array:
      return "array";
    case Kind::string:
      return "string";
    case Kind::integer:
      return "integer";
    case Kind::number:
      return "number";
    case Kind::boolean:
      return "boolean";
    case Kind::any:
      return "a value";
  }
  return "?";
}

bool hasKind(const Json::Value& v, Kind kind) {
  switch (kind) {
    case Kind::object:
    case Kind::any_object:
      return v.isObject();
    case Kind::array:
      return v.isArray();
    case Kind::string:
      return v.isString();
    case Kind::integer:
      return v.isInt64() || v.isUInt64();
    case Kind::number:
      return v.isNumeric();
    case Kind::boolean:
      return v.isBool();
    case Kind::any:
      return !v.isNull();
  }
  return false;
}

std::size_t editDistance(std::string_view a, std::string_view b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t above = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = above;
    }
  }
  return row[b.size()];
}

// The known key closest to `key`, when it is close enough to be a likely typo.
const Field* closestField(const std::vector<Field>& fields, std::string_view key) {
  const Field* best = nullptr;
  std::size_t best_distance = 0;
  for (const Field& f : fields) {
    const std::size_t d = editDistance(key, f.key);
    const std::size_t limit = std::min<std::size_t>(2, std::max<std::size_t>(1, f.key.size() / 3));
    if (d <= limit && (best == nullptr || d < best_distance)) {
      best = &f;
      best_distance = d;
    }
  }
  return best;
}

void checkRange(double v, const Schema& s, const std::string& path, Problems& out) {
  if (s.min && v < *s.min) {
    out.push_back({path, "must be >= " + formatNumber(*s.min) + ", got " + formatNumber(v)});
  } else if (s.max && v > *s.max) {
    out.push_back({path, "must be <= " + formatNumber(*s.max) + ", got " + formatNumber(v)});
  }
}

void checkString(const std::string& v, const Schema& s, const std::string& path, Problems& out) {
  if (s.non_empty && v.empty()) out.push_back({path, "must not be empty"});
  if (s.allowed.empty() || std::find(s.allowed.begin(), s.allowed.end(), v) != s.allowed.end()) {
    return;
  }
  std::string reason = "must be one of ";
  for (std::size_t i = 0; i < s.allowed.size(); ++i) {
    reason += (i ? ", " : "") + quoted(s.allowed[i]);
  }
  out.push_back({path, reason + ", got " + quoted(v)});
}

void checkObject(const Json::Value& v, const Schema& s, const std::string& path, Problems& out) {
  for (const Field& f : s.fields) {
    const Json::Value* member = v.find(f.key.data(), f.key.data() + f.key.size());
    if (member != nullptr) {
      Problems sub = validate(*member, f.schema, childPath(path, f.key));
      out.insert(out.end(), sub.begin(), sub.end());
    } else if (f.required) {
      out.push_back({childPath(path, f.key), "required key missing"});
    }
  }
  if (s.unknown_keys_allowed) return;
  for (const std::string& key : v.getMemberNames()) {
    const bool known =
        std::any_of(s.fields.begin(), s.fields.end(), [&](const Field& f) { return f.key == key; });
    if (known) continue;
    std::string reason = "unknown key " + quoted(key);
    if (const Field* near = closestField(s.fields, key)) {
      reason += " (did you mean " + quoted(near->key) + "?)";
    }
    out.push_back({path, std::move(reason)});
  }
}

void checkArray(const Json::Value& v, const Schema& s, const std::string& path, Problems& out) {
  const std::size_t n = v.size();
  if (n < s.min_items) {
    out.push_back({path, "must have at least " + std::to_string(s.min_items) + " items, got " +
                             std::to_string(n)});
  } else if (n > s.max_items) {
    out.push_back({path, "must have at most " + std::to_string(s.max_items) + " items, got " +
                             std::to_string(n)});
  }
  if (!s.element) return;
  for (Json::ArrayIndex i = 0; i < n; ++i) {
    Problems sub = validate(v[i], *s.element, indexPath(path, i));
    out.insert(out.end(), sub.begin(), sub.end());
  }
}

}  // namespace

Schema Schema::oneOf(std::vector<std::string> values) const {
  Schema s = *this;
  s.allowed = std::move(values);
  return s;
}
Schema Schema::nonEmpty() const {
  Schema s = *this;
  s.non_empty = true;
  return s;
}
Schema Schema::range(double lo, double hi) const {
  return atLeast(lo).atMost(hi);
}
Schema Schema::atLeast(double lo) const {
  Schema s = *this;
  s.min = lo;
  return s;
}
Schema Schema::atMost(double hi) const {
  Schema s = *this;
  s.max = hi;
  return s;
}
Schema Schema::items(std::size_t lo, std::size_t hi) const {
  Schema s = *this;
  s.min_items = lo;
  s.max_items = hi;
  return s;
}
Schema Schema::allowUnknownKeys() const {
  Schema s = *this;
  s.unknown_keys_allowed = true;
  return s;
}
Schema Schema::check(Check rule) const {
  Schema s = *this;
  s.checks.push_back(std::move(rule));
  return s;
}

Schema object(std::vector<Field> fields) {
  Schema s = ofKind(Kind::object);
  s.fields = std::move(fields);
  return s;
}
Schema arrayOf(Schema element) {
  Schema s = ofKind(Kind::array);
  s.element = std::make_shared<const Schema>(std::move(element));
  return s;
}
Schema string() {
  return ofKind(Kind::string);
}
Schema integer() {
  return ofKind(Kind::integer);
}
Schema number() {
  return ofKind(Kind::number);
}
Schema boolean() {
  return ofKind(Kind::boolean);
}
Schema anyObject() {
  return ofKind(Kind::any_object);
}
Schema any() {
  return ofKind(Kind::any);
}

Field required(std::string key, Schema schema) {
  return Field{std::move(key), std::move(schema), true, Json::Value()};
}
Field optional(std::string key, Schema schema, Json::Value default_value) {
  return Field{std::move(key), std::move(schema), false, std::move(default_value)};
}

Problems validate(const Json::Value& value, const Schema& schema, const std::string& path) {
  Problems out;
  if (!hasKind(value, schema.kind)) {
    std::string reason = "expected " + std::string(kindName(schema.kind)) + ", got ";
    // "got number" would be confusing for 1.5 where an integer is expected.
    reason += (schema.kind == Kind::integer && value.isNumeric())
                  ? "non-integral number"
                  : std::string(support::jsonTypeName(value));
    out.push_back({path, std::move(reason)});
    return out;
  }
  switch (schema.kind) {
    case Kind::object:
      checkObject(value, schema, path, out);
      break;
    case Kind::array:
      checkArray(value, schema, path, out);
      break;
    case Kind::string:
      checkString(value.asString(), schema, path, out);
      break;
    case Kind::integer:
    case Kind::number:
      checkRange(value.asDouble(), schema, path, out);
      break;
    case Kind::boolean:
    case Kind::any_object:
    case Kind::any:
      break;
  }
  if (out.empty() && !schema.checks.empty()) {
    const Json::Value filled = withDefaults(value, schema);
    for (const Check& rule : schema.checks) rule(filled, path, out);
  }
  return out;
}

Json::Value withDefaults(const Json::Value& value, const Schema& schema) {
  Json::Value out = value;
  if (schema.kind == Kind::object && value.isObject()) {
    for (const Field& f : schema.fields) {
      const Json::Value* member = value.find(f.key.data(), f.key.data() + f.key.size());
      if (member != nullptr) {
        out[f.key] = withDefaults(*member, f.schema);
      } else if (!f.default_value.isNull()) {
        out[f.key] = withDefaults(f.default_value, f.schema);
      }
    }
  } else if (schema.kind == Kind::array && value.isArray() && schema.element) {
    for (Json::ArrayIndex i = 0; i < value.size(); ++i) {
      out[i] = withDefaults(value[i], *schema.element);
    }
  }
  return out;
}

std::string childPath(const std::string& path, std::string_view key) {
  const auto identifier_char = [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_';
  };
  const bool plain = !key.empty() && !(key[0] >= '0' && key[0] <= '9') &&
                     std::all_of(key.begin(), key.end(), identifier_char);
  return plain ? path + "." + std::string(key) : path + "[" + quoted(key) + "]";
}

std::string indexPath(const std::string& path, std::size_t index) {
  return path + "[" + std::to_string(index) + "]";
}

std::string formatNumber(double value) {
  if (std::isfinite(value) && value == std::trunc(value) && std::fabs(value) < 1e15) {
    return std::to_string(static_cast<long long>(value));
  }
  char buf[32];
  const auto [end, ec] = std::to_chars(buf, buf + sizeof buf, value);
  return ec == std::errc() ? std::string(buf, end) : std::to_string(value);
}

std::string formatProblems(const Problems& problems, std::string_view origin) {
  std::string text;
  for (const Problem& p : problems) {
    if (!text.empty()) text += '\n';
    text += std::string(origin) + ": " + p.path + ": " + p.reason;
  }
  return text;
}

}  // namespace skr::schema
