// SPDX-License-Identifier: Apache-2.0
// variantToJsonText: the JSON mapping written straight from a Variant to text, without a
// Json::Value in between (values of modules and JSON twin commands pass here; a 64 KB string
// took 280 us through jsoncpp). Same text as Json::StreamWriter with emitUTF8, except float64:
// the shortest digits that read back to the same double.
#include "variant_json_text.h"

#include <skrobot/runtime/flow/variant.h>

#include <charconv>
#include <cmath>

namespace skr::flow {
namespace {

class JsonTextWriter {
 public:
  explicit JsonTextWriter(std::string& out) : out_(out) {}

  void value(const Variant& v) {
    switch (v.type()) {
      case Variant::Type::null:
        out_ += "null";
        return;
      case Variant::Type::boolean:
        out_ += *v.asBool() ? "true" : "false";
        return;
      case Variant::Type::int64:
        integer(*v.asInt64());
        return;
      case Variant::Type::uint64:
        integer(*v.asUint64());
        return;
      case Variant::Type::float64:
        real(*v.asDouble());
        return;
      case Variant::Type::string:
        text(*v.asString());
        return;
      case Variant::Type::bytes:
        out_ += "{\"$base64\":\"";
        out_ += base64Encode(v.asBytes()->data);
        out_ += "\"}";
        return;
      case Variant::Type::list: {
        out_ += '[';
        bool first = true;
        for (const Variant& item : *v.asList()) {
          if (!first) out_ += ',';
          first = false;
          value(item);
        }
        out_ += ']';
        return;
      }
      case Variant::Type::map: {
        const Variant::Map& m = *v.asMap();
        const bool escaped = json_keys::needsMapEscape(m);
        if (escaped) out_ += "{\"$map\":";
        members(m);
        if (escaped) out_ += '}';
        return;
      }
    }
    out_ += "null";
  }

 private:
  void members(const Variant::Map& m) {
    out_ += '{';
    bool first = true;
    for (const auto& [key, item] : m) {
      if (!first) out_ += ',';
      first = false;
      text(key);
      out_ += ':';
      value(item);
    }
    out_ += '}';
  }

  template <class Int>
  void integer(Int i) {
    char buf[24];
    const auto r = std::to_chars(buf, buf + sizeof buf, i);
    out_.append(buf, r.ptr);
  }

  // Non-finite numbers have no JSON form: null, as the mapping says. An integral double keeps a
  // ".0" so that it reads back as float64, not int64.
  void real(double d) {
    if (!std::isfinite(d)) {
      out_ += "null";
      return;
    }
    char buf[32];
    const auto r = std::to_chars(buf, buf + sizeof buf, d);
    const std::string_view digits(buf, static_cast<size_t>(r.ptr - buf));
    out_ += digits;
    if (digits.find_first_of(".e") == std::string_view::npos) out_ += ".0";
  }

  void text(std::string_view s) {
    out_.reserve(out_.size() + s.size() + 2);
    out_ += '"';
    const char* p = s.data();
    const char* const end = p + s.size();
    bool ascii = true;  // not needed here
    while (p != end) {
      const size_t run = json_keys::plainRun(p, end, ascii);
      out_.append(p, run);
      p += run;
      if (p != end) escape(static_cast<unsigned char>(*p++));
    }
    out_ += '"';
  }

  void escape(unsigned char c) {
    switch (c) {
      case '"':
        out_ += "\\\"";
        return;
      case '\\':
        out_ += "\\\\";
        return;
      case '\b':
        out_ += "\\b";
        return;
      case '\f':
        out_ += "\\f";
        return;
      case '\n':
        out_ += "\\n";
        return;
      case '\r':
        out_ += "\\r";
        return;
      case '\t':
        out_ += "\\t";
        return;
      default: {
        static constexpr char kHex[] = "0123456789abcdef";
        const char u[6] = {'\\', 'u', '0', '0', kHex[c >> 4], kHex[c & 15]};
        out_.append(u, sizeof u);
      }
    }
  }

  std::string& out_;
};

}  // namespace

std::string variantToJsonText(const Variant& v) {
  std::string out;
  JsonTextWriter(out).value(v);
  return out;
}

}  // namespace skr::flow
