// SPDX-License-Identifier: Apache-2.0
// variantFromJsonText: strict JSON text (RFC 8259) read straight into a Variant, with the
// mapping's escapes ({"$base64"}, {"$map"}) undone as each object closes. No Json::Value in
// between: values of modules and JSON twin commands pass here (a 64 KB string took 527 us
// through jsoncpp).
//
// Depth: the limit counts Variant levels, which an escape does not add, so the text may nest up
// to twice as deep; each value reports its height and the root's is checked at the end (the
// walk that names the place runs only when it is too deep). Recursion is bounded by the text's
// nesting, itself bounded by 2 x max_depth + 2.
#include "variant_json_text.h"

#include <skrobot/runtime/flow/variant.h>

#include <algorithm>
#include <charconv>
#include <cstring>
#include <limits>
#include <memory>
#include <vector>

namespace skr::flow {
namespace {

// Where a value sits, for messages: "$", "$.pose[2]", keys shortened to 64 bytes. Built on the
// stack as the parser descends; turned into text only when something fails.
struct PathStep {
  const PathStep* parent = nullptr;
  std::string_view key;  // a member's key, or empty for an item
  size_t index = 0;
  bool is_key = false;
};

void appendKey(std::string& out, std::string_view key) {
  out += '.';
  out.append(key.substr(0, 64));
  if (key.size() > 64) out += "...";
}

std::string pathText(const PathStep* at) {
  std::vector<const PathStep*> steps;
  for (; at != nullptr && at->parent != nullptr; at = at->parent) steps.push_back(at);
  std::string out = "$";
  for (auto it = steps.rbegin(); it != steps.rend(); ++it) {
    if ((*it)->is_key) {
      appendKey(out, (*it)->key);
    } else {
      out += '[' + std::to_string((*it)->index) + ']';
    }
  }
  return out;
}

// The first value (depth first, keys in order) deeper than `max`, as fromJson() would name it.
std::string tooDeep(const Variant& v, size_t depth, size_t max, const std::string& path) {
  if (depth > max) {
    return path + ": nesting depth " + std::to_string(depth) + " exceeds the limit of " +
           std::to_string(max);
  }
  if (const Variant::List* l = v.asList()) {
    for (size_t i = 0; i < l->size(); ++i) {
      std::string found = tooDeep((*l)[i], depth + 1, max, path + "[" + std::to_string(i) + "]");
      if (!found.empty()) return found;
    }
  } else if (const Variant::Map* m = v.asMap()) {
    for (const auto& [key, item] : *m) {
      std::string at = path;
      appendKey(at, key);
      std::string found = tooDeep(item, depth + 1, max, at);
      if (!found.empty()) return found;
    }
  }
  return {};
}

class JsonTextReader {
 public:
  JsonTextReader(std::string_view text, size_t max_depth)
      : begin_(text.data()),
        p_(text.data()),
        end_(text.data() + text.size()),
        max_depth_(max_depth),
        max_nesting_(2 * max_depth + 2) {}

  Result<Variant> read() {
    const PathStep root;
    Parsed v;
    if (!value(v, 1, root) || !finish(v, root)) return makeError(Errc::parse_error, error_);
    skipSpace();
    if (p_ != end_) return syntax(p_, "Extra non-whitespace after JSON value.");
    if (v.height > max_depth_) {
      return makeError(Errc::parse_error, tooDeep(v.value, 1, max_depth_, "$"));
    }
    return std::move(v.value);
  }

 private:
  // A value as read. An object whose single key is "$base64" or "$map" is an escape candidate:
  // what it is depends on the enclosing value (the object inside a "$map" escape is a map as is),
  // so its member stays in `member`, unfinished, until finish() or asMap() decides.
  struct Parsed {
    Variant value;
    size_t height = 1;        // Variant levels
    std::string_view escape;  // the candidate's key, or empty
    std::unique_ptr<Parsed> member;
  };

  // The value this is wherever it is not the content of a "$map" escape.
  bool finish(Parsed& v, const PathStep& at) {
    if (v.escape.empty()) return true;
    Parsed inner = std::move(*v.member);
    const bool bytes = v.escape == json_keys::kBase64;
    v.escape = {};
    v.member.reset();
    if (bytes) {
      const std::string* text = inner.value.asString();
      if (text == nullptr) return fail(pathText(&at) + ": \"$base64\" must hold a string");
      std::optional<std::string> decoded = base64Decode(*text);
      if (!decoded) return fail(pathText(&at) + ": \"$base64\" holds invalid base64");
      v.value = Variant(Variant::Bytes(std::move(*decoded)));
      v.height = 1;
      return true;
    }
    if (!inner.value.isMap()) return fail(pathText(&at) + ": \"$map\" must hold an object");
    if (!asMap(inner, at)) return false;
    v = std::move(inner);
    return true;
  }

  // An object taken as a plain map: a candidate's member becomes an ordinary value.
  bool asMap(Parsed& v, const PathStep& at) {
    if (v.escape.empty()) return true;
    Parsed inner = std::move(*v.member);
    const PathStep step{&at, v.escape, 0, true};
    if (!finish(inner, step)) return false;
    Variant::Map m;
    m.emplace(std::string(v.escape), std::move(inner.value));
    v.value = Variant(std::move(m));
    v.height = inner.height + 1;
    v.escape = {};
    v.member.reset();
    return true;
  }

  // `nesting` counts the text's levels, which bound the recursion.
  bool value(Parsed& out, size_t nesting, const PathStep& at) {
    if (nesting > max_nesting_) {
      return fail(pathText(&at) + ": nesting depth " + std::to_string(nesting) +
                  " exceeds the limit of " + std::to_string(max_depth_));
    }
    skipSpace();
    if (p_ == end_) return syntaxFail(p_, "Syntax error: value, object or array expected.");
    switch (*p_) {
      case '{':
        return object(out, nesting, at);
      case '[':
        return list(out, nesting, at);
      case '"': {
        std::string s;
        bool ascii = true;
        if (!string(s, ascii)) return false;
        if (!ascii && !isValidUtf8(s)) return fail(pathText(&at) + ": string is not valid UTF-8");
        out.value = Variant(std::move(s));
        return true;
      }
      case 't':
        return literal("true", out.value, Variant(true));
      case 'f':
        return literal("false", out.value, Variant(false));
      case 'n':
        return literal("null", out.value, Variant());
      default:
        if (*p_ == '-' || (*p_ >= '0' && *p_ <= '9')) return number(out.value);
        return syntaxFail(p_, "Syntax error: value, object or array expected.");
    }
  }

  bool list(Parsed& out, size_t nesting, const PathStep& at) {
    ++p_;  // '['
    Variant::List items;
    size_t height = 0;
    skipSpace();
    if (p_ != end_ && *p_ == ']') {
      ++p_;
      out.value = Variant(std::move(items));
      return true;
    }
    for (;;) {
      const PathStep step{&at, {}, items.size(), false};
      Parsed item;
      if (!value(item, nesting + 1, step) || !finish(item, step)) return false;
      height = std::max(height, item.height);
      items.push_back(std::move(item.value));
      skipSpace();
      if (p_ != end_ && *p_ == ',') {
        ++p_;
        continue;
      }
      if (p_ != end_ && *p_ == ']') {
        ++p_;
        out.value = Variant(std::move(items));
        out.height = height + 1;
        return true;
      }
      return syntaxFail(p_, "Missing ',' or ']' in array declaration");
    }
  }

  bool object(Parsed& out, size_t nesting, const PathStep& at) {
    ++p_;  // '{'
    Variant::Map members;
    Parsed last;  // the value of the only member, while there is one
    size_t height = 0;
    skipSpace();
    if (p_ != end_ && *p_ == '}') {
      ++p_;
      out.value = Variant(std::move(members));
      return true;
    }
    for (;;) {
      skipSpace();
      const char* key_at = p_;
      if (p_ == end_ || *p_ != '"') return syntaxFail(p_, "Missing '}' or object member name");
      std::string key;
      bool ascii = true;
      if (!string(key, ascii)) return false;
      if (key.size() > std::numeric_limits<uint16_t>::max()) {
        return fail(pathText(&at) + ": key of " + std::to_string(key.size()) +
                    " bytes exceeds 65535");
      }
      if (!ascii && !isValidUtf8(key)) return fail(pathText(&at) + ": key is not valid UTF-8");
      skipSpace();
      if (p_ == end_ || *p_ != ':') return syntaxFail(p_, "Missing ':' after object member name");
      ++p_;
      if (members.find(key) != members.end()) {
        return syntaxFail(key_at, "Duplicate key: '" + key + "'");
      }
      Parsed item;
      {
        const PathStep step{&at, key, 0, true};
        if (!value(item, nesting + 1, step)) return false;
        // The first member stays as read until we know whether it is the only one.
        if (!members.empty() && !finish(item, step)) return false;
      }
      if (members.size() == 1) {  // a second member: the first is an ordinary value after all
        auto first = members.begin();
        const PathStep step{&at, first->first, 0, true};
        if (!finish(last, step)) return false;
        first->second = std::move(last.value);
        height = last.height;
      }
      height = std::max(height, item.height);
      if (members.empty()) {
        members.emplace(std::move(key), Variant());
        last = std::move(item);
      } else {
        members.emplace(std::move(key), std::move(item.value));
      }
      skipSpace();
      if (p_ != end_ && *p_ == ',') {
        ++p_;
        continue;
      }
      if (p_ != end_ && *p_ == '}') {
        ++p_;
        break;
      }
      return syntaxFail(p_, "Missing ',' or '}' in object declaration");
    }
    if (members.size() > 1) {
      out.value = Variant(std::move(members));
      out.height = height + 1;
      return true;
    }
    const std::string& key = members.begin()->first;
    if (key == json_keys::kBase64 || key == json_keys::kMap) {
      out.escape = key == json_keys::kBase64 ? json_keys::kBase64 : json_keys::kMap;
      out.member = std::make_unique<Parsed>(std::move(last));
      out.value = Variant(Variant::Map{});  // an object, whatever it turns out to be
      return true;
    }
    const PathStep step{&at, key, 0, true};
    if (!finish(last, step)) return false;
    members.begin()->second = std::move(last.value);
    out.value = Variant(std::move(members));
    out.height = last.height + 1;
    return true;
  }

  // A string token into `out`, escapes decoded. `ascii` is cleared when raw bytes >= 0x80 were
  // copied: only then must the caller check the UTF-8.
  bool string(std::string& out, bool& ascii) {
    const char* start = p_++;  // '"'
    for (;;) {
      const size_t run = json_keys::plainRun(p_, end_, ascii);
      out.append(p_, run);
      p_ += run;
      if (p_ == end_) return syntaxFail(start, "Missing '\"' at the end of a string");
      if (*p_ == '"') {
        ++p_;
        return true;
      }
      if (*p_ != '\\') return syntaxFail(p_, "Control character in a string: escape it");
      if (!escape(out)) return false;
    }
  }

  bool escape(std::string& out) {
    const char* at = p_++;  // '\\'
    if (p_ == end_) return syntaxFail(at, "Bad escape sequence in string");
    switch (*p_++) {
      case '"':
        out += '"';
        return true;
      case '\\':
        out += '\\';
        return true;
      case '/':
        out += '/';
        return true;
      case 'b':
        out += '\b';
        return true;
      case 'f':
        out += '\f';
        return true;
      case 'n':
        out += '\n';
        return true;
      case 'r':
        out += '\r';
        return true;
      case 't':
        out += '\t';
        return true;
      case 'u':
        return unicode(at, out);
      default:
        return syntaxFail(at, "Bad escape sequence in string");
    }
  }

  // \uXXXX, a surrogate pair as two of them; a lone surrogate is refused.
  bool unicode(const char* at, std::string& out) {
    uint32_t cp = 0;
    if (!hex4(cp)) return syntaxFail(at, "Bad unicode escape sequence in string");
    if (cp >= 0xDC00 && cp <= 0xDFFF) return syntaxFail(at, "Lone surrogate in string");
    if (cp >= 0xD800 && cp <= 0xDBFF) {
      uint32_t low = 0;
      if (end_ - p_ < 2 || p_[0] != '\\' || p_[1] != 'u') {
        return syntaxFail(at, "Lone surrogate in string");
      }
      p_ += 2;
      if (!hex4(low)) return syntaxFail(at, "Bad unicode escape sequence in string");
      if (low < 0xDC00 || low > 0xDFFF) return syntaxFail(at, "Lone surrogate in string");
      cp = 0x10000 + ((cp - 0xD800) << 10) + (low - 0xDC00);
    }
    appendUtf8(out, cp);
    return true;
  }

  bool hex4(uint32_t& cp) {
    if (end_ - p_ < 4) return false;
    for (int i = 0; i < 4; ++i) {
      const char c = *p_++;
      int d = 0;
      if (c >= '0' && c <= '9') {
        d = c - '0';
      } else if (c >= 'a' && c <= 'f') {
        d = c - 'a' + 10;
      } else if (c >= 'A' && c <= 'F') {
        d = c - 'A' + 10;
      } else {
        return false;
      }
      cp = (cp << 4) | static_cast<uint32_t>(d);
    }
    return true;
  }

  static void appendUtf8(std::string& out, uint32_t cp) {
    if (cp < 0x80) {
      out += static_cast<char>(cp);
    } else if (cp < 0x800) {
      out += static_cast<char>(0xC0 | (cp >> 6));
      out += static_cast<char>(0x80 | (cp & 0x3F));
    } else if (cp < 0x10000) {
      out += static_cast<char>(0xE0 | (cp >> 12));
      out += static_cast<char>(0x80 | ((cp >> 6) & 0x3F));
      out += static_cast<char>(0x80 | (cp & 0x3F));
    } else {
      out += static_cast<char>(0xF0 | (cp >> 18));
      out += static_cast<char>(0x80 | ((cp >> 12) & 0x3F));
      out += static_cast<char>(0x80 | ((cp >> 6) & 0x3F));
      out += static_cast<char>(0x80 | (cp & 0x3F));
    }
  }

  // -?(0|[1-9][0-9]*)(.[0-9]+)?([eE][+-]?[0-9]+)?. An integer gives int64 when it fits, else
  // uint64, else float64; anything with a fraction or an exponent gives float64.
  bool number(Variant& out) {
    const char* start = p_;
    auto digits = [this] {
      const char* from = p_;
      while (p_ != end_ && *p_ >= '0' && *p_ <= '9') ++p_;
      return p_ - from;
    };
    auto bad = [&] {
      while (p_ != end_ && (std::strchr("+-.eE", *p_) != nullptr || (*p_ >= '0' && *p_ <= '9'))) {
        ++p_;
      }
      return syntaxFail(start, "'" + std::string(start, p_) + "' is not a number.");
    };
    if (*p_ == '-') ++p_;
    const char* int_part = p_;
    if (digits() == 0) return bad();
    if (*int_part == '0' && p_ - int_part > 1) return bad();  // no leading zeros
    bool integral = true;
    if (p_ != end_ && *p_ == '.') {
      ++p_;
      if (digits() == 0) return bad();
      integral = false;
    }
    if (p_ != end_ && (*p_ == 'e' || *p_ == 'E')) {
      ++p_;
      if (p_ != end_ && (*p_ == '+' || *p_ == '-')) ++p_;
      if (digits() == 0) return bad();
      integral = false;
    }
    if (integral) {
      if (*start == '-') {
        int64_t i = 0;
        if (std::from_chars(start, p_, i).ec == std::errc()) {
          out = Variant(i);
          return true;
        }
      } else {
        uint64_t u = 0;
        if (std::from_chars(start, p_, u).ec == std::errc()) {
          if (u <= static_cast<uint64_t>(std::numeric_limits<int64_t>::max())) {
            out = Variant(static_cast<int64_t>(u));
          } else {
            out = Variant(u);
          }
          return true;
        }
      }
    }
    double d = 0;
    if (std::from_chars(start, p_, d).ec != std::errc()) return bad();  // beyond a double's range
    out = Variant(d);
    return true;
  }

  bool literal(std::string_view word, Variant& out, Variant v) {
    if (static_cast<size_t>(end_ - p_) < word.size() || std::string_view(p_, word.size()) != word) {
      return syntaxFail(p_, "Syntax error: value, object or array expected.");
    }
    p_ += word.size();
    out = std::move(v);
    return true;
  }

  void skipSpace() {
    while (p_ != end_ && (*p_ == ' ' || *p_ == '\n' || *p_ == '\r' || *p_ == '\t')) ++p_;
  }

  // "Line 3, Column 7: <what>" (1-based, columns in bytes).
  std::string located(const char* at, const std::string& what) const {
    size_t line = 1;
    const char* line_start = begin_;
    for (const char* c = begin_; c < at; ++c) {
      if (*c == '\n') ++line, line_start = c + 1;
    }
    return "Line " + std::to_string(line) + ", Column " + std::to_string(at - line_start + 1) +
           ": " + what;
  }

  Error syntax(const char* at, const std::string& what) const {
    return makeError(Errc::parse_error, located(at, what));
  }
  bool syntaxFail(const char* at, const std::string& what) { return fail(located(at, what)); }
  bool fail(std::string message) {
    error_ = std::move(message);
    return false;
  }

  const char* begin_;
  const char* p_;
  const char* end_;
  size_t max_depth_;
  size_t max_nesting_;
  std::string error_;
};

}  // namespace

Result<Variant> variantFromJsonText(std::string_view text, const DecodeLimits& limits) {
  if (text.size() > limits.max_bytes) {
    return makeError(Errc::parse_error, "JSON text of " + std::to_string(text.size()) +
                                            " bytes exceeds the limit of " +
                                            std::to_string(limits.max_bytes));
  }
  return JsonTextReader(text, limits.max_depth).read();
}

}  // namespace skr::flow
