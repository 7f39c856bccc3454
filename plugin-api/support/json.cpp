// SPDX-License-Identifier: Apache-2.0
#include <skrobot/base64.hpp>
#include <skrobot/support/json.hpp>

#include <json/reader.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <exception>
#include <memory>

namespace skr::support {
namespace {

// Length of the valid UTF-8 sequence at s[i], or 0 when there is none.
std::size_t utf8Length(std::string_view s, std::size_t i) noexcept {
  const auto c = static_cast<unsigned char>(s[i]);
  std::size_t n = 0;
  std::uint32_t min = 0;
  if (c < 0x80) return 1;
  if ((c & 0xe0) == 0xc0) {
    n = 2;
    min = 0x80;
  } else if ((c & 0xf0) == 0xe0) {
    n = 3;
    min = 0x800;
  } else if ((c & 0xf8) == 0xf0) {
    n = 4;
    min = 0x10000;
  } else {
    return 0;
  }
  if (i + n > s.size()) return 0;
  std::uint32_t cp = c & (0x7fu >> n);
  for (std::size_t k = 1; k < n; ++k) {
    const auto d = static_cast<unsigned char>(s[i + k]);
    if ((d & 0xc0) != 0x80) return 0;
    cp = cp << 6 | (d & 0x3fu);
  }
  if (cp < min || cp > 0x10ffff || (cp >= 0xd800 && cp <= 0xdfff)) return 0;
  return n;
}

void appendQuoted(std::string& out, std::string_view text) {
  static constexpr char kHex[] = "0123456789abcdef";
  out += '"';
  for (std::size_t i = 0; i < text.size();) {
    const auto c = static_cast<unsigned char>(text[i]);
    if (c >= 0x80) {
      const std::size_t n = utf8Length(text, i);
      if (n == 0) {
        out += "\xef\xbf\xbd";  // U+FFFD for a byte that starts no valid sequence
        ++i;
      } else {
        out.append(text.substr(i, n));
        i += n;
      }
      continue;
    }
    switch (c) {
      case '"':
        out += "\\\"";
        break;
      case '\\':
        out += "\\\\";
        break;
      case '\n':
        out += "\\n";
        break;
      case '\r':
        out += "\\r";
        break;
      case '\t':
        out += "\\t";
        break;
      case '\b':
        out += "\\b";
        break;
      case '\f':
        out += "\\f";
        break;
      default:
        if (c < 0x20 || c == 0x7f) {
          out += "\\u00";
          out += kHex[c >> 4];
          out += kHex[c & 0xf];
        } else {
          out += static_cast<char>(c);
        }
    }
    ++i;
  }
  out += '"';
}

void appendDouble(std::string& out, double v) {
  if (!std::isfinite(v)) {
    out += "null";
    return;
  }
  char buf[64];
  const auto [end, ec] = std::to_chars(buf, buf + sizeof buf, v);
  if (ec != std::errc()) {  // cannot happen with 64 bytes; stay valid JSON anyway
    out += "null";
    return;
  }
  const std::string_view text(buf, static_cast<std::size_t>(end - buf));
  out += text;
  if (text.find_first_of(".eE") == std::string_view::npos) out += ".0";
}

void append(std::string& out, const Json::Value& v) {
  switch (v.type()) {
    case Json::nullValue:
      out += "null";
      break;
    case Json::intValue:
      out += std::to_string(v.asLargestInt());
      break;
    case Json::uintValue:
      out += std::to_string(v.asLargestUInt());
      break;
    case Json::realValue:
      appendDouble(out, v.asDouble());
      break;
    case Json::booleanValue:
      out += v.asBool() ? "true" : "false";
      break;
    case Json::stringValue: {
      const char* begin = nullptr;
      const char* end = nullptr;
      if (v.getString(&begin, &end)) {
        appendQuoted(out, std::string_view(begin, static_cast<std::size_t>(end - begin)));
      } else {
        out += "\"\"";
      }
      break;
    }
    case Json::arrayValue: {
      out += '[';
      for (Json::ArrayIndex i = 0; i < v.size(); ++i) {
        if (i != 0) out += ',';
        append(out, v[i]);
      }
      out += ']';
      break;
    }
    case Json::objectValue: {
      out += '{';
      bool first = true;
      for (auto it = v.begin(); it != v.end(); ++it) {
        if (!first) out += ',';
        first = false;
        const char* kend = nullptr;
        const char* key = it.memberName(&kend);
        appendQuoted(out, std::string_view(key, static_cast<std::size_t>(kend - key)));
        out += ':';
        append(out, *it);
      }
      out += '}';
      break;
    }
  }
}

// jsoncpp's "* Line 1, Column 2\n  Syntax error: ...\n" as "line 1, column 2: Syntax error: ...";
// several errors are joined with "; ".
std::string oneLine(std::string_view errors) {
  std::string out;
  bool detail_started = false;
  while (!errors.empty()) {
    const std::size_t nl = errors.find('\n');
    std::string_view line = errors.substr(0, nl);
    errors = nl == std::string_view::npos ? std::string_view() : errors.substr(nl + 1);
    while (!line.empty() && (line.front() == ' ' || line.front() == '\t')) line.remove_prefix(1);
    while (!line.empty() && (line.back() == ' ' || line.back() == '\r')) line.remove_suffix(1);
    if (line.empty()) continue;
    if (line.substr(0, 2) == "* ") {
      line.remove_prefix(2);
      if (!out.empty()) out += "; ";
      if (line.substr(0, 5) == "Line ") {
        out += "line ";
        line.remove_prefix(5);
        const std::size_t col = line.find(", Column ");
        if (col != std::string_view::npos) {
          out += line.substr(0, col);
          out += ", column ";
          out += line.substr(col + 9);
          line = {};
        }
      }
      out += line;
      detail_started = false;
      continue;
    }
    out += detail_started ? " " : ": ";
    out += line;
    detail_started = true;
  }
  return out.empty() ? std::string("invalid JSON") : out;
}

// Checks what jsoncpp lets through or cannot survive, before it runs: nesting deeper than
// max_depth (its recursion would reach its own, throwing, limit) and raw control characters
// (JSON allows only tab, line feed and carriage return, as whitespace; jsoncpp copies them into
// strings and takes a NUL for the end of the text).
Result<void> prescan(std::string_view text, std::size_t max_depth) {
  std::size_t depth = 0, line = 1, column = 0;
  bool in_string = false, escaped = false;
  const auto where = [&] {
    return "line " + std::to_string(line) + ", column " + std::to_string(column);
  };
  for (const char ch : text) {
    const auto c = static_cast<unsigned char>(ch);
    ++column;
    if (c < 0x20 && (in_string || (c != '\t' && c != '\n' && c != '\r'))) {
      static constexpr char kHex[] = "0123456789abcdef";
      return makeError(Errc::parse_error, std::string("control character 0x") + kHex[c >> 4] +
                                              kHex[c & 0xf] + " at " + where());
    }
    if (c == '\n') {
      ++line;
      column = 0;
    }
    if (in_string) {
      if (escaped) {
        escaped = false;
      } else if (c == '\\') {
        escaped = true;
      } else if (c == '"') {
        in_string = false;
      }
      continue;
    }
    if (c == '"') {
      in_string = true;
    } else if (c == '[' || c == '{') {
      if (++depth > max_depth) {
        return makeError(Errc::limit_exceeded, "JSON nesting deeper than " +
                                                   std::to_string(max_depth) + " at " + where());
      }
    } else if ((c == ']' || c == '}') && depth > 0) {
      --depth;
    }
  }
  return {};
}

}  // namespace

Result<Json::Value> parseJson(std::string_view text, JsonLimits limits) {
  if (text.size() > limits.max_bytes) {
    return makeError(Errc::limit_exceeded, "JSON text of " + std::to_string(text.size()) +
                                               " bytes exceeds the limit of " +
                                               std::to_string(limits.max_bytes) + " bytes");
  }
  if (auto checked = prescan(text, limits.max_depth); !checked) return checked.error();
  try {
    Json::CharReaderBuilder builder;
    Json::CharReaderBuilder::strictMode(&builder.settings_);
    builder["strictRoot"] = false;  // any value at the root
    builder["stackLimit"] = static_cast<Json::UInt>(limits.max_depth + 8);
    const std::unique_ptr<Json::CharReader> reader(builder.newCharReader());
    Json::Value root;
    std::string errors;
    if (!reader->parse(text.data(), text.data() + text.size(), &root, &errors)) {
      return makeError(Errc::parse_error, oneLine(errors));
    }
    return root;
  } catch (const std::exception& e) {
    return makeError(Errc::parse_error, std::string("JSON parser: ") + e.what());
  } catch (...) {
    return makeError(Errc::parse_error, "JSON parser failed");
  }
}

Result<Json::Value> parseJsonObject(std::string_view text, JsonLimits limits) {
  auto parsed = parseJson(text, limits);
  if (parsed.ok() && !parsed->isObject()) {
    return makeError(Errc::parse_error,
                     "expected a JSON object, got " + std::string(jsonTypeName(*parsed)));
  }
  return parsed;
}

std::string writeJson(const Json::Value& value) {
  try {
    std::string out;
    append(out, value);
    return out;
  } catch (...) {  // out of memory: an empty answer is better than an exception across C
    return "null";
  }
}

std::string jsonQuote(std::string_view text) {
  std::string out;
  out.reserve(text.size() + 2);
  appendQuoted(out, text);
  return out;
}

std::string_view jsonTypeName(const Json::Value& value) noexcept {
  switch (value.type()) {
    case Json::nullValue:
      return "null";
    case Json::intValue:
    case Json::uintValue:
      return "integer";
    case Json::realValue:
      return "number";
    case Json::stringValue:
      return "string";
    case Json::booleanValue:
      return "boolean";
    case Json::arrayValue:
      return "array";
    case Json::objectValue:
      return "object";
  }
  return "unknown";
}

Json::Value jsonBytes(std::string_view bytes) {
  Json::Value v(Json::objectValue);
  v["$base64"] = base64::encode(bytes);
  return v;
}

}  // namespace skr::support
